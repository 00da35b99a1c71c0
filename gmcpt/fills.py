"""Fills without learned parameters, which the completion methods and the generator start from.

:func:`guided_fill` is the feature-guided fill (docs/design.md section 5): on
demodulated, log-compressed radiance, each missing pixel becomes a
cross-bilateral weighted mean of the traced pixels in a window around it, with
weights from the spatial distance and from differences in albedo, shading
normal, depth and light visibility, so edges and shadow boundaries that the
features see are respected. Where no traced neighbour is similar enough, the
feature-blind :func:`push_pull` (pyramid) fill takes over. :func:`interpolate`
runs it on a whole frame: the ``interp`` method, and the baseline training
reports beside the generator. The generator corrects the same fill with the
traced pixels smoothed too (:func:`gmcpt.gan.model.smoothed_fill`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .domain import WorkingDomain
from .frame import SparseFrame
from .workers import cpu_threads, torch_threads


@dataclass(frozen=True)
class GuidedFillParams:
    """Bandwidths of the feature-guided fill.

    ``radius=None`` picks ``ceil(1.5 / sqrt(rate))`` (about 15 traced pixels in
    the window at any rate). Feature bandwidths are standard deviations of the
    Gaussian on each feature's difference; depth differences are relative.
    """

    radius: int | None = None
    sigma_albedo: float = 0.1
    sigma_normal: float = 0.3
    sigma_depth: float = 0.05
    sigma_visibility: float = 0.25
    min_weight: float = 1e-3


def _quarters(image: np.ndarray) -> tuple[np.ndarray, ...]:
    """The four pixels of every 2x2 block of (2h, 2w, ...) ``image``: top left, top right, bottom left,
    bottom right, each (h, w, ...)."""
    top, bottom = image[0::2], image[1::2]
    return top[:, 0::2], top[:, 1::2], bottom[:, 0::2], bottom[:, 1::2]


def upsampled(bins: np.ndarray, size: int, height: int, width: int) -> np.ndarray:
    """Each bin's value on its ``size`` x ``size`` pixels: (rows, columns, ...) ``bins`` to (height, width, ...),
    cropped (the coarse level of :func:`push_pull`, the bins of :mod:`gmcpt.placement`)."""
    rows, columns, *rest = bins.shape
    blocks = np.empty((rows, size, columns, size, *rest), bins.dtype)
    blocks[...] = bins[:, None, :, None]
    return blocks.reshape(rows * size, columns * size, *rest)[:height, :width]


def _pushed(values: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The next level of :func:`push_pull`'s pyramid: (values, weights) of the 2x2 blocks, an odd side padded
    by zeros. The block sums add the four quarters of each block in the order numpy's ``reshape(...).sum``
    takes for 3-channel images (the same result to the bit there, in half the time)."""
    height, width = weights.shape
    even = ((0, height % 2), (0, width % 2))
    weighted = values * weights[..., None]
    if height % 2 or width % 2:
        weights, weighted = np.pad(weights, even), np.pad(weighted, even + ((0, 0),))
    top_left, top_right, bottom_left, bottom_right = _quarters(weights)
    sum_w = (top_left + top_right) + (bottom_left + bottom_right)
    top_left, top_right, bottom_left, bottom_right = _quarters(weighted)
    sum_v = top_left + top_right
    sum_v += bottom_left
    sum_v += bottom_right
    return sum_v / np.maximum(sum_w[..., None], 1e-12), np.minimum(sum_w, 1.0)


def push_pull(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Fill an (H, W, C) image from samples with (H, W) weights in [0, 1].

    Pushes weighted sums down a 2x2 pyramid (:func:`_pushed`) and pulls the coarse estimate back
    up where fine weights are missing.
    """
    height, width = weights.shape
    if weights.sum() == 0:
        return np.zeros_like(values)
    if max(height, width) <= 1:
        return values * weights[..., None] / np.maximum(weights[..., None], 1e-12)
    coarse = push_pull(*_pushed(values, weights))
    alpha = weights[..., None]
    return alpha * values + (1.0 - alpha) * upsampled(coarse, 2, height, width)


def pulled_at(values: np.ndarray, weights: np.ndarray, rows: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """``push_pull(values, weights)[rows, columns]``, (n, C), without the full-size blend of every level: the
    guided fill needs the pyramid at a few hundred pixels of a frame, not at its millions."""
    if weights.sum() == 0:
        return np.zeros((len(rows),) + values.shape[2:], values.dtype)
    if max(weights.shape) <= 1:
        return (values * weights[..., None] / np.maximum(weights[..., None], 1e-12))[rows, columns]
    coarse = pulled_at(*_pushed(values, weights), rows // 2, columns // 2)
    alpha = weights[rows, columns][:, None]
    return alpha * values[rows, columns] + (1.0 - alpha) * coarse


def fill_radius(rate: float, params: GuidedFillParams = GuidedFillParams()) -> int:
    """The guided fill's window radius at sampling ``rate``: ``params.radius``, else about 15 traced pixels in it."""
    return params.radius or max(1, math.ceil(1.5 / math.sqrt(max(rate, 1e-6))))


def with_fallback(filled: np.ndarray, confident: np.ndarray, values: np.ndarray, mask: np.ndarray,
                  keep_samples: bool) -> np.ndarray:
    """``filled`` (H, W, C) with the pyramid fill of ``values`` where a pixel is not ``confident`` (no traced
    neighbour similar enough); there a traced pixel keeps its sample."""
    unsure = np.nonzero(~confident)
    if len(unsure[0]):
        fallback = pulled_at(values * mask[..., None], mask.astype(np.float32), *unsure)
        filled[unsure] = fallback if keep_samples else np.where(mask[unsure][:, None], values[unsure], fallback)
    return filled


def guided_fill(values: np.ndarray, mask: np.ndarray, features: np.ndarray,
                params: GuidedFillParams = GuidedFillParams(), keep_samples: bool = True) -> np.ndarray:
    """Fill the pixels outside ``mask`` from those inside it (in torch: :func:`fill_batch`).

    Parameters
    ----------
    values : (H, W, C) image, valid where ``mask``.
    mask : (H, W) bool.
    features : (H, W, 8) albedo (3), normal (3), depth, visibility.
    params : bandwidths.
    keep_samples : True keeps the traced pixels as they are; False gives them the same
        feature-weighted average of the traced pixels around them (themselves included) as the
        others get, which smooths their noise.

    Returns
    -------
    (H, W, C) float32 image, equal to ``values`` on the mask if ``keep_samples``.
    """
    import torch  # loaded when a fill runs, not by every module that reaches this one

    planes = lambda image: torch.from_numpy(np.ascontiguousarray(np.moveaxis(image, -1, 0), np.float32))[None]  # noqa: E731
    filled = fill_batch(planes(values), torch.from_numpy(np.asarray(mask, bool))[None], planes(features), params,
                        keep_samples, threads=cpu_threads())
    return np.ascontiguousarray(filled[0].permute(1, 2, 0).numpy())


def fill_batch(values, mask, features,
               params: GuidedFillParams = GuidedFillParams(), keep_samples: bool = True,
               threads: int | None = None):
    """:func:`guided_fill` of each image of a batch of torch tensors: ``values`` (B, C, H, W), ``mask`` (B, H, W)
    bool, ``features`` (B, 8, H, W), on their device; float32 (B, C, H, W) there (torch loads on the first call).
    Each image gets the radius of its own rate; the few pixels without a similar traced neighbour take the
    pyramid fill, on the CPU. ``threads``: torch's threads on the CPU (None: as set)."""
    import torch

    from .fill_kernel import weighted_mean

    filled = torch.empty(values.shape, dtype=torch.float32, device=values.device)
    pixels = mask.shape[1] * mask.shape[2]
    radii = [fill_radius(traced / pixels, params) for traced in mask.flatten(1).sum(1).tolist()]
    with torch_threads(threads or torch.get_num_threads()):
        for radius in sorted(set(radii)):
            members = [index for index, own in enumerate(radii) if own == radius]
            chosen = torch.tensor(members, device=values.device)
            mean, weight = weighted_mean(values[chosen], mask[chosen], features[chosen], radius, params)
            filled[chosen] = mean
            unsure = (weight <= params.min_weight).flatten(1).any(1).tolist()
            for place in (place for place, any_unsure in enumerate(unsure) if any_unsure):
                index = members[place]
                image = with_fallback(_pixels(mean[place]), _pixels(weight[place]) > params.min_weight,
                                      _pixels(values[index]), _pixels(mask[index]), keep_samples=False)
                filled[index] = torch.from_numpy(image).permute(2, 0, 1).to(filled.device)
    if keep_samples:
        filled = torch.where(mask[:, None], values.float(), filled)
    return filled


def _pixels(tensor) -> np.ndarray:
    """A (C, H, W) or (H, W) tensor as a numpy array of (H, W, C) or (H, W), on the host."""
    array = tensor.detach().cpu().numpy()
    return np.moveaxis(array, 0, -1) if array.ndim == 3 else array


def interpolate(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                params: GuidedFillParams = GuidedFillParams()) -> np.ndarray:
    """(H, W, 3) float32: the frame filled by :func:`guided_fill` in the working domain; traced pixels keep
    their exact samples (no round-off from the transform)."""
    working, factor = domain.encode(frame)
    filled = guided_fill(working, frame.mask, frame.features(), params)
    image = domain.inverse(filled, factor)
    return np.where(frame.mask[..., None], frame.radiance, image).astype(np.float32)
