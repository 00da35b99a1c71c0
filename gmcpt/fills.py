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


def push_pull(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Fill an (H, W, C) image from samples with (H, W) weights in [0, 1].

    Pushes weighted sums down a 2x2 pyramid and pulls the coarse estimate back
    up where fine weights are missing.
    """
    height, width = weights.shape
    total = weights.sum()
    if total == 0:
        return np.zeros_like(values)
    if max(height, width) <= 1:
        return values * weights[..., None] / np.maximum(weights[..., None], 1e-12)
    ph, pw = height % 2, width % 2
    padded_w = np.pad(weights, ((0, ph), (0, pw)))
    padded_v = np.pad(values * weights[..., None], ((0, ph), (0, pw), (0, 0)))
    sum_w = padded_w.reshape(padded_w.shape[0] // 2, 2, -1, 2).sum(axis=(1, 3))
    sum_v = padded_v.reshape(padded_v.shape[0] // 2, 2, padded_v.shape[1] // 2, 2, -1).sum(axis=(1, 3))
    coarse_w = np.minimum(sum_w, 1.0)
    coarse_v = sum_v / np.maximum(sum_w[..., None], 1e-12)
    coarse = push_pull(coarse_v, coarse_w)
    up = np.repeat(np.repeat(coarse, 2, axis=0), 2, axis=1)[:height, :width]
    alpha = weights[..., None]
    return alpha * values + (1.0 - alpha) * up


def _shift(array: np.ndarray, dy: int, dx: int, pad: int) -> np.ndarray:
    """View of a padded array shifted by (dy, dx), cropped to the original size."""
    height = array.shape[0] - 2 * pad
    width = array.shape[1] - 2 * pad
    return array[pad + dy: pad + dy + height, pad + dx: pad + dx + width]


def guided_fill(values: np.ndarray, mask: np.ndarray, features: np.ndarray,
                params: GuidedFillParams = GuidedFillParams(), keep_samples: bool = True) -> np.ndarray:
    """Fill the pixels outside ``mask`` from those inside it.

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
    rate = max(mask.mean(), 1e-6)
    radius = params.radius or max(1, math.ceil(1.5 / math.sqrt(rate)))
    pad = radius
    sigma_space = max(radius / 2.0, 0.5)
    # exp(-distance) with distance = |scaled feature difference|^2; depth differences are relative
    # to the pixel's own depth, so depth is scaled per pixel rather than once
    scale = np.float32(math.sqrt(0.5)) * np.array([1 / params.sigma_albedo] * 3 + [1 / params.sigma_normal] * 3
                                                  + [1 / params.sigma_visibility], np.float32)
    scaled = np.concatenate([features[..., 0:6], features[..., 7:8]], axis=-1).astype(np.float32) * scale
    depth = features[..., 6].astype(np.float32)
    depth_scale = np.float32(math.sqrt(0.5) / params.sigma_depth) / np.maximum(depth, np.float32(1e-3))
    padded_values = np.pad((values * mask[..., None]).astype(np.float32), ((pad, pad), (pad, pad), (0, 0)))
    padded_mask = np.pad(mask.astype(np.float32), pad)
    padded_scaled = np.pad(scaled, ((pad, pad), (pad, pad), (0, 0)), mode="edge")
    padded_depth = np.pad(depth, pad, mode="edge")
    numerator = np.zeros(values.shape, np.float32)
    denominator = np.zeros(mask.shape, np.float32)
    for dy in range(-radius, radius + 1):
        for dx in range(-radius, radius + 1):
            if dy * dy + dx * dx > radius * radius:
                continue
            difference = _shift(padded_scaled, dy, dx, pad) - scaled
            distance = np.einsum("ijk,ijk->ij", difference, difference)
            distance += ((_shift(padded_depth, dy, dx, pad) - depth) * depth_scale) ** 2
            distance += np.float32((dy * dy + dx * dx) / (2 * sigma_space ** 2))
            weight = _shift(padded_mask, dy, dx, pad) * np.exp(-distance)
            numerator += weight[..., None] * _shift(padded_values, dy, dx, pad)
            denominator += weight
    fallback = push_pull(values * mask[..., None], mask.astype(np.float32))
    confident = denominator > params.min_weight
    guided = numerator / np.maximum(denominator, 1e-12)[..., None]
    filled = np.where(confident[..., None], guided, fallback)
    if not keep_samples:
        return np.where(mask[..., None] & ~confident[..., None], values, filled).astype(np.float32)
    return np.where(mask[..., None], values, filled).astype(np.float32)


def interpolate(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                params: GuidedFillParams = GuidedFillParams()) -> np.ndarray:
    """(H, W, 3) float32: the frame filled by :func:`guided_fill` in the working domain; traced pixels keep
    their exact samples (no round-off from the transform)."""
    working, factor = domain.encode(frame)
    filled = guided_fill(working, frame.mask, frame.features(), params)
    image = domain.inverse(filled, factor)
    return np.where(frame.mask[..., None], frame.radiance, image).astype(np.float32)
