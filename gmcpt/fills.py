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


def push_pull(values: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Fill an (H, W, C) image from samples with (H, W) weights in [0, 1].

    Pushes weighted sums down a 2x2 pyramid and pulls the coarse estimate back
    up where fine weights are missing. The block sums add the four quarters of each block in the order
    numpy's ``reshape(...).sum`` takes for 3-channel images (the same result to the bit there, in half
    the time).
    """
    height, width = weights.shape
    total = weights.sum()
    if total == 0:
        return np.zeros_like(values)
    if max(height, width) <= 1:
        return values * weights[..., None] / np.maximum(weights[..., None], 1e-12)
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
    coarse_w = np.minimum(sum_w, 1.0)
    coarse_v = sum_v / np.maximum(sum_w[..., None], 1e-12)
    coarse = push_pull(coarse_v, coarse_w)
    alpha = weights[:height, :width, None]
    return alpha * values + (1.0 - alpha) * upsampled(coarse, 2, height, width)


#: Pixels of the band of rows the fill works on at a time: a band's planes stay in the CPU's cache across
#: the offsets of the window (rate 0.3: 256x256 0.036 s, 1024x1024 0.55 s; whole planes 0.09 and 1.2 s;
#: bands of 2^14 pixels 0.055 and 0.60 s, 2^16 0.039 and 0.63 s).
BAND_PIXELS = 1 << 15


def _window(radius: int) -> list[tuple[int, int]]:
    """The offsets of a disc of ``radius`` pixels."""
    return [(dy, dx) for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)
            if dy * dy + dx * dx <= radius * radius]


def _weighted_sums(values: np.ndarray, mask: np.ndarray, planes: np.ndarray, norms: np.ndarray, depth: np.ndarray,
                   depth_scale: np.ndarray, radius: int, sigma_space: float, rows: slice):
    """(numerator (C, n, W), denominator (n, W)) of the fill's weighted mean for the ``n`` output rows
    ``rows``; the inputs are channel-first planes padded by ``radius`` on every side (features, their
    squared norms and depth by their edge values, values and mask by 0), ``depth_scale`` unpadded.

    The squared feature distance is ``|a|^2 + |b|^2 - 2 a.b``, the dot product one pass over the planes
    (an ``einsum``): a third less time than differences squared and summed (256x256 at rate 0.2: 21 ->
    15 ms), within 5e-6 of them relative to the sums."""
    pad = radius
    height, width = rows.stop - rows.start, depth.shape[1] - 2 * pad
    here = (slice(rows.start + pad, rows.stop + pad), slice(pad, pad + width))
    centre, centre_norm = planes[(slice(None),) + here], norms[here]
    centre_depth, scale = depth[here], depth_scale[rows]
    numerator = np.zeros((values.shape[0], height, width), np.float32)
    denominator = np.zeros((height, width), np.float32)
    distance = np.empty((height, width), np.float32)
    dot = np.empty((height, width), np.float32)
    value_terms = np.empty(numerator.shape, np.float32)
    for dy, dx in _window(radius):
        there = (slice(rows.start + pad + dy, rows.stop + pad + dy), slice(pad + dx, pad + dx + width))
        np.einsum("khw,khw->hw", planes[(slice(None),) + there], centre, out=dot)
        np.subtract(depth[there], centre_depth, out=distance)
        np.multiply(distance, scale, out=distance)
        np.square(distance, out=distance)
        distance += norms[there]
        distance += centre_norm
        dot *= np.float32(2.0)
        distance -= dot
        distance += np.float32((dy * dy + dx * dx) / (2 * sigma_space ** 2))
        np.negative(distance, out=distance)
        np.exp(distance, out=distance)
        distance *= mask[there]
        denominator += distance
        np.multiply(values[(slice(None),) + there], distance, out=value_terms)
        numerator += value_terms
    return numerator, denominator


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
    planes = np.pad(np.moveaxis(scaled, -1, 0), ((0, 0), (pad, pad), (pad, pad)), mode="edge")
    norms = np.einsum("khw,khw->hw", planes, planes)
    padded_values = np.pad(np.moveaxis(values * mask[..., None], -1, 0).astype(np.float32),
                           ((0, 0), (pad, pad), (pad, pad)))
    padded_mask = np.pad(mask.astype(np.float32), pad)
    padded_depth = np.pad(depth, pad, mode="edge")
    numerator = np.empty((values.shape[-1],) + mask.shape, np.float32)
    denominator = np.empty(mask.shape, np.float32)
    band = max(1, BAND_PIXELS // mask.shape[1])
    for first in range(0, mask.shape[0], band):
        rows = slice(first, min(first + band, mask.shape[0]))
        numerator[:, rows], denominator[rows] = _weighted_sums(padded_values, padded_mask, planes, norms,
                                                               padded_depth, depth_scale, radius, sigma_space, rows)
    confident = denominator > params.min_weight
    guided = np.moveaxis(numerator, 0, -1) / np.maximum(denominator, 1e-12)[..., None]
    filled = guided
    if not confident.all():  # the pyramid fill only where no traced neighbour is similar enough
        fallback = push_pull(values * mask[..., None], mask.astype(np.float32))
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
