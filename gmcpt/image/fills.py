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

from ..frame import SparseFrame
from ..runtime.workers import cpu_threads, map_threads
from .domain import WorkingDomain


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
    cropped (the coarse level of :func:`push_pull`, the bins of :mod:`gmcpt.sampling.placement`)."""
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


def _padded_planes(channels: list[tuple[np.ndarray, object]], pad: int, edge: bool) -> np.ndarray:
    """(n, H + 2 pad, W + 2 pad) float32 planes of the products ``array * factor`` of (H, W) ``channels``,
    written in place (no stacked copy to pad after), padded by their edge values (``edge``) or by zeros."""
    height, width = channels[0][0].shape
    planes = (np.empty if edge else np.zeros)((len(channels), height + 2 * pad, width + 2 * pad), np.float32)
    for plane, (array, factor) in zip(planes, channels):
        np.multiply(array, factor, out=plane[pad:pad + height, pad:pad + width])
    if edge and pad:
        inner = slice(pad, pad + height)
        planes[:, inner, :pad] = planes[:, inner, pad:pad + 1]
        planes[:, inner, pad + width:] = planes[:, inner, pad + width - 1:pad + width]
        planes[:, :pad] = planes[:, pad:pad + 1]
        planes[:, pad + height:] = planes[:, pad + height - 1:pad + height]
    return planes


#: Pixels of the band of rows the fill works on at a time, so that a band's planes stay in the CPU's cache
#: across the offsets of the window (measured: docs/experiments.md, "Figures moved out of the code").
BAND_PIXELS = 1 << 15


def _half_window(radius: int) -> list[tuple[int, int]]:
    """The offsets of a disc of ``radius`` pixels after (0, 0) in row-major order: one of each pair ``o``, ``-o``."""
    return [(dy, dx) for dy in range(0, radius + 1) for dx in range(-radius, radius + 1)
            if (dy, dx) > (0, 0) and dy * dy + dx * dx <= radius * radius]


def _weighted_sums(values: np.ndarray, mask: np.ndarray, planes: np.ndarray, norms: np.ndarray, depth: np.ndarray,
                   depth_scale: np.ndarray, radius: int, sigma_space: float, rows: slice):
    """(numerator (C, n, W), denominator (n, W)) of the fill's weighted mean for the ``n`` output rows
    ``rows``; the inputs are channel-first planes padded by ``radius`` on every side (features, their
    squared norms and depth by their edge values, values and mask by 0), ``depth_scale`` unpadded.

    The squared feature distance is ``|a|^2 + |b|^2 - 2 a.b``, the dot product one pass over the planes
    (an ``einsum``), and it is symmetric: one plane of it over the band and its margin serves the offsets
    ``o`` and ``-o`` (the depth term, relative to the centre's depth, is not, and is computed for each)."""
    pad = radius
    height, width = rows.stop - rows.start, depth.shape[1] - 2 * pad
    here = (slice(rows.start + pad, rows.stop + pad), slice(pad, pad + width))
    centre_depth, scale = depth[here], depth_scale[rows]
    numerator = values[(slice(None),) + here] * mask[here]  # the centre's own weight is 1
    denominator = mask[here].copy()
    weight = np.empty((height, width), np.float32)
    value_terms = np.empty(numerator.shape, np.float32)
    for dy, dx in _half_window(radius):
        # minus the squared distance of q and q + o, for every q that is a centre or a neighbour in the band
        top, left, right = rows.start + pad - dy, pad + min(0, -dx), pad + width + max(0, -dx)
        first, second = (slice(top, rows.stop + pad), slice(left, right)), \
            (slice(top + dy, rows.stop + pad + dy), slice(left + dx, right + dx))
        similarity = np.einsum("khw,khw->hw", planes[(slice(None),) + first], planes[(slice(None),) + second])
        similarity *= np.float32(2.0)
        similarity -= norms[first]
        similarity -= norms[second]
        similarity -= np.float32((dy * dy + dx * dx) / (2 * sigma_space ** 2))
        # the pair (p, p + o) sits at p in it, the pair (p, p - o) at p - o
        for sy, sx, row, column in ((dy, dx, dy, pad - left), (-dy, -dx, 0, pad - left - dx)):
            there = (slice(rows.start + pad + sy, rows.stop + pad + sy), slice(pad + sx, pad + width + sx))
            np.subtract(depth[there], centre_depth, out=weight)
            weight *= scale
            np.square(weight, out=weight)
            np.subtract(similarity[row:row + height, column:column + width], weight, out=weight)
            np.exp(weight, out=weight)
            weight *= mask[there]
            denominator += weight
            np.multiply(values[(slice(None),) + there], weight, out=value_terms)
            numerator += value_terms
    return numerator, denominator


#: the feature channels (albedo 3, normal 3, depth, visibility) the fill compares as they are; depth is relative
COMPARED_CHANNELS = (0, 1, 2, 3, 4, 5, 7)
DEPTH_CHANNEL = 6


def feature_scales(params: GuidedFillParams) -> np.ndarray:
    """float32 factors of the :data:`COMPARED_CHANNELS`: exp(-distance) with distance = |scaled difference|^2."""
    return np.float32(math.sqrt(0.5)) * np.array([1 / params.sigma_albedo] * 3 + [1 / params.sigma_normal] * 3
                                                 + [1 / params.sigma_visibility], np.float32)


def depth_bandwidth(params: GuidedFillParams) -> np.float32:
    """The depth difference's factor, divided by the pixel's own depth (depth differences are relative)."""
    return np.float32(math.sqrt(0.5) / params.sigma_depth)


def space_sigma(radius: int) -> float:
    """The spatial Gaussian's standard deviation in pixels for a window of ``radius``."""
    return max(radius / 2.0, 0.5)


def fill_radius(rate: float, params: GuidedFillParams = GuidedFillParams()) -> int:
    """The guided fill's window radius at sampling ``rate``: ``params.radius``, else about 15 traced pixels in it."""
    return params.radius or max(1, math.ceil(1.5 / math.sqrt(max(rate, 1e-6))))


def with_fallback(filled: np.ndarray, confident: np.ndarray, values: np.ndarray, mask: np.ndarray,
                  keep_samples: bool) -> np.ndarray:
    """``filled`` (H, W, C) with the pyramid fill of ``values`` where a pixel is not ``confident`` (no traced
    neighbour similar enough); there a traced pixel keeps its sample unless ``keep_samples`` (which puts every
    traced sample back afterwards anyway)."""
    unsure = np.nonzero(~confident)
    if len(unsure[0]):
        fallback = pulled_at(values * mask[..., None], mask.astype(np.float32), *unsure)
        filled[unsure] = fallback if keep_samples else np.where(mask[unsure][:, None], values[unsure], fallback)
    return filled


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
    radius = fill_radius(mask.mean(), params)
    pad = radius
    sigma_space = space_sigma(radius)
    planes = _padded_planes([(features[..., channel], factor)
                             for channel, factor in zip(COMPARED_CHANNELS, feature_scales(params))], pad, edge=True)
    depth = features[..., DEPTH_CHANNEL].astype(np.float32)
    depth_scale = depth_bandwidth(params) / np.maximum(depth, np.float32(1e-3))
    norms = np.einsum("khw,khw->hw", planes, planes)
    padded_values = _padded_planes([(values[..., channel], mask) for channel in range(values.shape[-1])], pad, False)
    padded_mask = np.pad(mask.astype(np.float32), pad)
    padded_depth = np.pad(depth, pad, mode="edge")
    band = max(1, BAND_PIXELS // mask.shape[1])
    bands = [slice(first, min(first + band, mask.shape[0])) for first in range(0, mask.shape[0], band)]
    # numpy's loops release the GIL: bands on threads use every core (each band's sums are its own)
    sums = map_threads(lambda rows: _weighted_sums(padded_values, padded_mask, planes, norms, padded_depth,
                                                   depth_scale, radius, sigma_space, rows), bands, cpu_threads())
    numerator = np.concatenate([numerator for numerator, _ in sums], axis=1)
    denominator = np.concatenate([denominator for _, denominator in sums], axis=0)
    filled = np.moveaxis(numerator, 0, -1) / np.maximum(denominator, 1e-12)[..., None]
    filled = with_fallback(filled, denominator > params.min_weight, values, mask, keep_samples)
    return np.where(mask[..., None], values, filled).astype(np.float32) if keep_samples else filled


def fill_batch(values, mask, features, params: GuidedFillParams = GuidedFillParams(), keep_samples: bool = True):
    """:func:`guided_fill` of each image of a batch of torch tensors, where they are (a GPU: the generator's
    training batch): ``values`` (B, C, H, W), ``mask`` (B, H, W) bool, ``features`` (B, 8, H, W); float32
    (B, C, H, W) on their device, within float rounding of :func:`guided_fill` (:mod:`gmcpt.image.fill_kernel`). Each
    image gets the radius of its own rate; the few pixels without a similar traced neighbour take the pyramid fill, on
    the host. On a CPU :func:`guided_fill` is as fast and runs its bands on the process's threads."""
    import torch  # loaded by the first batch, not by every module that reaches this one

    from .fill_kernel import weighted_mean

    filled = torch.empty(values.shape, dtype=torch.float32, device=values.device)
    pixels = mask.shape[1] * mask.shape[2]
    radii = [fill_radius(traced / pixels, params) for traced in mask.flatten(1).sum(1).tolist()]
    for radius in sorted(set(radii)):
        members = [index for index, own in enumerate(radii) if own == radius]
        chosen = torch.tensor(members, device=values.device)
        mean, weight = weighted_mean(values[chosen], mask[chosen], features[chosen][:, list(COMPARED_CHANNELS)],
                                     features[chosen][:, DEPTH_CHANNEL], radius, feature_scales(params),
                                     depth_bandwidth(params), space_sigma(radius))
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
