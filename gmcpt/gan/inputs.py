"""Network inputs of a sparse frame, shared by inference and training.

The generator sees (all in the working domain of :mod:`gmcpt.domain`, divided by 255):

- ``radiance`` (3): sparse demodulated, log-compressed radiance, 0 where not traced;
- ``features``: mask, albedo (3), normal (3), depth, visibility and, when the
  config asks, the standard deviation of each traced pixel's mean (delta
  method, 0 elsewhere, clipped at 1) and the feature pass's coverage.

Inference imports this module, never :mod:`gmcpt.gan.data` (the training loader), so that
completing a frame needs no dataset or renderer code (``tests/test_layers.py`` checks it).
"""
from __future__ import annotations

import numpy as np
import torch

from ..domain import WorkingDomain, frame_coverage
from ..frame import SparseFrame

SCALE = 255.0


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


def frame_inputs(frame: SparseFrame, domain: WorkingDomain, use_variance: bool, use_coverage: bool = False
                 ) -> tuple[torch.Tensor, torch.Tensor, np.ndarray]:
    """(radiance (1, 3, H, W), features (1, F, H, W), factor (H, W, 3)) of a sparse frame."""
    factor = domain.frame_factor(frame)
    working = domain.forward_traced(frame.radiance, factor, frame.mask) / SCALE
    std = working_std(domain, frame.radiance, frame.variance, factor, frame.mask) if use_variance else None
    coverage = frame_coverage(frame) if use_coverage else None
    features = feature_stack(frame.mask, frame.albedo, frame.normal, frame.depth, frame.visibility, std, coverage)
    # (H, W, C) arrays seen as (1, C, H, W) without a copy: channels-last tensors, as the generator runs on a CPU
    as_tensor = lambda array: torch.from_numpy(np.asarray(array, np.float32)).permute(2, 0, 1)[None]  # noqa: E731
    return as_tensor(working), as_tensor(features), factor
