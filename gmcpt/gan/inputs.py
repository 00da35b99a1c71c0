"""Network inputs of a sparse frame, shared by inference and training.

The generator sees (all in the working domain of :mod:`gmcpt.image.domain`, divided by 255):

- ``radiance`` (3): sparse demodulated, log-compressed radiance, 0 where not traced;
- ``features``: mask, albedo (3), normal (3), depth, visibility and, when the
  config asks, the standard deviation of each traced pixel's mean (delta
  method, 0 elsewhere, clipped at 1) and the feature pass's coverage.

Inference imports this module, never :mod:`gmcpt.gan.data` (the training loader), which reads the dataset's
files; no module of the GAN reaches the dataset builder or the renderer (``tests/test_layers.py``). Inference
needs no torch either: a CPU runtime (:mod:`gmcpt.gan.runtime`) takes the numpy arrays of :func:`network_arrays`; PyTorch
sees them as channels-last tensors without a copy (:func:`as_tensor`, :func:`gmcpt.gan.infer.network_inputs`).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from ..frame import SparseFrame
from ..image.domain import WorkingDomain, channel_mean, frame_coverage
from ..image.fills import guided_fill

SCALE = 255.0
#: Feature channels: mask, albedo (3), normal (3), depth, visibility.
FEATURE_CHANNELS = 9
#: Brightness the product brings a frame to before the generator sees it (the 95th percentile of the traced
#: pixels' mean radiance, the statistic the dataset builder sets when it picks a scene's exposure): brighter
#: frames put more of the image on the working domain's logarithmic part, where noise is closer to uniform
#: (chosen on the validation split: docs/experiments.md, "Figures moved out of the code").
EXPOSURE_TARGET = 2.5


def target_exposure(frame: SparseFrame, target: float = EXPOSURE_TARGET) -> float:
    """The factor that brings the 95th percentile of the traced pixels' mean radiance to ``target``.

    1 for a frame with no traced pixels; clipped to [1e-2, 1e3] like the dataset's exposures.
    """
    if not frame.mask.any():
        return 1.0
    level = float(np.percentile(channel_mean(frame.radiance[frame.mask]), 95))
    return float(np.clip(target / max(level, 1e-6), 1e-2, 1e3))


def exposed(frame: SparseFrame, exposure: float) -> SparseFrame:
    """The frame with its radiance scaled by ``exposure`` (and its variance by ``exposure ** 2``)."""
    return dataclasses.replace(frame, radiance=(frame.radiance * exposure).astype(np.float32),
                               variance=(frame.variance * exposure ** 2).astype(np.float32))


def feature_stack(mask: np.ndarray, albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray,
                  visibility: np.ndarray, std: np.ndarray | None, coverage: np.ndarray | None = None,
                  axis: int = -1) -> np.ndarray:
    """(H, W, F) float32 features in the generator's channel order (``std`` and ``coverage`` where given),
    joined in one copy; ``axis`` is the channels' axis (1 for a training batch's (B, F, c, c))."""
    parts = [np.expand_dims(mask, axis), albedo, normal, np.expand_dims(depth, axis), np.expand_dims(visibility, axis)]
    parts += [np.expand_dims(extra, axis) for extra in (std, coverage) if extra is not None]
    return np.concatenate(parts, axis=axis, dtype=np.float32)


def working_std(domain: WorkingDomain, radiance: np.ndarray, variance: np.ndarray, factor: np.ndarray,
                mask: np.ndarray) -> np.ndarray:
    """Standard deviation of traced pixels in the working domain / 255, clipped to [0, 1]."""
    std = np.sqrt(np.maximum(domain.variance(radiance, variance, factor), 0.0)) / SCALE
    return np.where(mask, np.minimum(std, 1.0), 0.0).astype(np.float32)


def frame_arrays(frame: SparseFrame, domain: WorkingDomain, use_variance: bool, use_coverage: bool = False
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(radiance (H, W, 3), features (H, W, F), factor (H, W, 3)) of a sparse frame, float32."""
    factor = domain.frame_factor(frame)
    working = domain.forward_traced(frame.radiance, factor, frame.mask) / SCALE
    std = working_std(domain, frame.radiance, frame.variance, factor, frame.mask) if use_variance else None
    coverage = frame_coverage(frame) if use_coverage else None
    features = feature_stack(frame.mask, frame.albedo, frame.normal, frame.depth, frame.visibility, std, coverage)
    return np.asarray(working, np.float32), features, factor


def as_tensor(array: np.ndarray):
    """A (B, H, W, C) array seen as a (B, C, H, W) torch tensor without a copy: channels last, as the generator
    runs on a CPU."""
    import torch

    return torch.from_numpy(array).permute(0, 3, 1, 2)


def smoothed_fill_arrays(radiance: np.ndarray, features: np.ndarray) -> np.ndarray:
    """The fill the generator corrects, of (B, H, W, 3) ``radiance`` from (B, H, W, F) ``features``: the
    feature-guided fill with the traced pixels smoothed by the same weights (``guided_fill`` with
    ``keep_samples=False``)."""
    mask, guides = features[..., 0] > 0, features[..., 1:FEATURE_CHANNELS]
    return np.stack([guided_fill(radiance[i], mask[i], guides[i], keep_samples=False) for i in range(len(radiance))])


def network_arrays(frame: SparseFrame, domain: WorkingDomain, use_variance: bool, use_coverage: bool, multiple: int
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(radiance, features, fill, each (1, H', W', C); factor (H, W, 3)) of ``frame`` for a generator whose sides
    are multiples of ``multiple``: padded (reflected, or repeated where the frame is no larger than a multiple) on
    the bottom and the right, the fill made once for the whole frame."""
    radiance, features, factor = frame_arrays(frame, domain, use_variance, use_coverage)
    height, width = frame.shape
    pad = ((0, -height % multiple), (0, -width % multiple), (0, 0))
    if any(pad[0] + pad[1]):
        mode = "reflect" if min(height, width) > multiple else "edge"
        radiance, features = np.pad(radiance, pad, mode=mode), np.pad(features, pad, mode=mode)
    radiance, features = radiance[None], features[None]
    return radiance, features, smoothed_fill_arrays(radiance, features), factor


def working_image(output: np.ndarray, shape: tuple[int, int], factor: np.ndarray, exposure: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(the generator's (1, H', W', 3) ``output`` cropped to the frame's ``shape``, in the working domain
    (0..255-like, not negative); the demodulation factor with the ``exposure`` folded in)."""
    height, width = shape
    working = output[0, :height, :width] * SCALE
    return np.maximum(working, 0.0).astype(np.float32), factor / np.float32(exposure)
