"""Where to spend the samples: sampling densities for the ``adaptive`` and ``two_pass`` masks.

Completion errs where the pixels it fills differ from the traced ones around them in ways the
feature buffers do not explain: silhouettes, texture and normal edges, contact and sun shadows,
glossy highlights. A density is an (H, W) array of non-negative weights, mean 1; the masks in
:mod:`gmcpt.sampling.masks` turn it into exactly ``round(rate * H * W)`` pixels whose chance of being
traced follows it.

- :func:`feature_density`: edges of albedo, normal, depth and visibility from the feature pass
  (it runs before the radiance pass, so this costs no render), plus the pixels without a diffuse
  albedo (glass, metal: nothing to demodulate by), over a floor so flat regions keep samples.
- :func:`error_density`: after a first radiance pass, where the traced samples disagree with their
  traced neighbours beyond their noise (structure no feature predicted), and where they are noisy.

All functions are pure numpy, O(H W), a few milliseconds at 256x256.
"""
from __future__ import annotations

import numpy as np

from ..image.domain import WorkingDomain, channel_mean, pixel_coverage
from ..image.fills import upsampled

#: Share of every density that is spread evenly (the floor), so that no region is left without samples; 0.3
#: scored best with OIDN as the last stage (docs/experiments.md, "Figures moved out of the code").
FLOOR = 0.3
#: Edge weight above the floor: ``1 + EDGE_GAIN * min(edge / mean(edge), EDGE_CAP)`` before mixing.
EDGE_GAIN = 4.0
EDGE_CAP = 8.0
#: Extra weight of a pixel whose feature rays saw no diffuse albedo (glass, metal, emitters).
SPECULAR_GAIN = 1.0
#: The feature edges are found on bins of EDGE_BIN x EDGE_BIN pixels (the buffers' means) and given to every
#: pixel of the bin: a band two pixels wider about each edge, less moved by the feature pass's noise (measured:
#: docs/experiments.md, "Figures moved out of the code").
EDGE_BIN = 2
#: Fraction of the pixel budget the first pass of ``two_pass`` spends.
FIRST_PASS_SHARE = 0.5
#: The second pass compares traced samples over windows of ERROR_WINDOW x ERROR_WINDOW bins of
#: ERROR_BIN x ERROR_BIN pixels (6 x 6 pixels; binning makes it a quarter of the work).
ERROR_BIN = 2
ERROR_WINDOW = 3
DEPTH_EPS = 1e-3


def first_pass_count(pixels: int) -> int:
    """Pixels of ``two_pass``'s first pass when the frame traces ``pixels`` in all (at least one)."""
    return max(1, int(round(pixels * FIRST_PASS_SHARE)))


def feature_edges(albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray,
                  visibility: np.ndarray) -> np.ndarray:
    """(H, W) float32 edge strength in [0, 1]: the largest difference to a 4-neighbour of any channel of
    albedo, normal (halved), log depth and visibility (clipped to 1), widened by one pixel so both sides
    of an edge count."""
    height, width = depth.shape
    log_depth = np.maximum(depth, DEPTH_EPS, dtype=np.float32)
    np.log(log_depth, out=log_depth)
    # (plane, scale): halving a difference is exact, so it equals the difference of halved normals
    planes = [(albedo[..., 0], 1.0), (albedo[..., 1], 1.0), (albedo[..., 2], 1.0), (normal[..., 0], 0.5),
              (normal[..., 1], 0.5), (normal[..., 2], 0.5), (log_depth, 1.0), (visibility, 1.0)]
    dx = np.zeros((height, width - 1), np.float32)
    dy = np.zeros((height - 1, width), np.float32)
    # one scratch buffer a direction: each fresh full-frame temporary costs page faults in a render
    step_x, step_y = np.empty_like(dx), np.empty_like(dy)
    for plane, scale in planes:  # one channel at a time: a max over a short last axis is ten times slower
        for largest, step, ahead, behind in ((dx, step_x, plane[:, 1:], plane[:, :-1]),
                                             (dy, step_y, plane[1:], plane[:-1])):
            np.subtract(ahead, behind, out=step)
            np.abs(step, out=step)
            if scale != 1.0:
                step *= np.float32(scale)
            np.maximum(largest, step, out=largest)
    edges = np.zeros((height + 2, width + 2), np.float32)  # padded: the widening below needs no bounds checks
    inner = edges[1:-1, 1:-1]
    np.maximum(inner[:, 1:], dx, out=inner[:, 1:])
    np.maximum(inner[:, :-1], dx, out=inner[:, :-1])
    np.maximum(inner[1:], dy, out=inner[1:])
    np.maximum(inner[:-1], dy, out=inner[:-1])
    np.minimum(inner, 1.0, out=inner)
    widened = np.maximum(edges[:, :-2], edges[:, 1:-1])
    np.maximum(widened, edges[:, 2:], out=widened)
    result = np.maximum(widened[:-2], widened[1:-1])
    return np.maximum(result, widened[2:], out=result)


def _normalise(weight: np.ndarray, floor: float) -> np.ndarray:
    """Mix float32 ``weight`` with an even density (``floor`` of the total), scaled to mean 1, in place."""
    mean = float(weight.mean())
    if mean <= 0:
        weight.fill(1.0)
        return weight
    weight *= (1.0 - floor) / mean
    weight += floor
    return weight


def _capped_weight(values: np.ndarray) -> np.ndarray:
    """``EDGE_GAIN * min(values / mean(values), EDGE_CAP)`` of float32 ``values``, in place."""
    mean = float(values.mean())
    if mean <= 0:
        values.fill(0.0)
        return values
    np.minimum(values, EDGE_CAP * mean, out=values)
    values *= EDGE_GAIN / mean
    return values


def feature_density(albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray, visibility: np.ndarray,
                    coverage: np.ndarray | None = None, floor: float = FLOOR) -> np.ndarray:
    """(H, W) float32 sampling density from the feature buffers, mean 1: :func:`feature_edges` of the
    buffers' means over :data:`EDGE_BIN` x :data:`EDGE_BIN` bins, given to each bin's pixels.

    Parameters
    ----------
    albedo, normal : (H, W, 3) feature buffers.
    depth, visibility : (H, W) feature buffers.
    coverage : (H, W) fraction of feature rays with a diffuse albedo (None: from ``albedo``).
    floor : share of the density spread evenly, in [0, 1].
    """
    coverage = pixel_coverage(albedo) if coverage is None else coverage
    height, width = depth.shape
    edges = binned_edges(albedo, normal, depth, visibility)
    # 1 + EDGE_GAIN * capped edges + SPECULAR_GAIN * (1 - coverage), in place: few full-frame temporaries
    weight = _capped_weight(upsampled(edges, EDGE_BIN, height, width))
    weight += 1.0 + SPECULAR_GAIN
    uncovered = np.clip(coverage, 0.0, 1.0, dtype=np.float32)
    uncovered *= np.float32(SPECULAR_GAIN)
    weight -= uncovered
    return _normalise(weight, floor)


def binned_edges(albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray, visibility: np.ndarray) -> np.ndarray:
    """:func:`feature_edges` of the buffers' means over :data:`EDGE_BIN` x :data:`EDGE_BIN` bins, one value a bin.
    Their mean is the share of the frame near a feature edge (:func:`gmcpt.sampling.budget.choose` reads it)."""
    return feature_edges(*(_binned_mean(buffer, EDGE_BIN) for buffer in (albedo, normal, depth, visibility)))


def _binned_mean(image: np.ndarray, size: int) -> np.ndarray:
    """Means of (H, W, ...) ``image`` over ``size`` x ``size`` bins, float32; a partial last bin repeats
    the image's last row or column. Rows are added first, whole rows at a time (contiguous): 0.19 ms for
    a (256, 256, 3) buffer, against 0.33 ms adding the four strided sub-images."""
    height, width = image.shape[:2]
    padding = [(0, -height % size), (0, -width % size)] + [(0, 0)] * (image.ndim - 2)
    if any(after for _, after in padding):
        image = np.pad(image, padding, mode="edge")
    rows = image[0::size].astype(np.float32)
    for row in range(1, size):
        rows += image[row::size]
    total = rows[:, 0::size].copy()
    for column in range(1, size):
        total += rows[:, column::size]
    total *= np.float32(1.0 / (size * size))
    return total


def _window_sums(plane: np.ndarray, window: int) -> np.ndarray:
    """Sums of (H, W) ``plane`` over ``window`` x ``window`` neighbourhoods (odd), edges repeated."""
    radius = window // 2
    height, width = plane.shape
    padded = np.pad(plane, radius, mode="edge")
    rows = padded[:height].copy()  # summed in place: one buffer a direction
    for shift in range(1, window):
        rows += padded[shift:shift + height]
    total = rows[:, :width].copy()
    for shift in range(1, window):
        total += rows[:, shift:shift + width]
    return total


def _disagreement(pixels: np.ndarray, values: np.ndarray, noise: np.ndarray, mask: np.ndarray,
                  edges_density: np.ndarray, floor: float) -> np.ndarray:
    """The second pass's density from the traced pixels ``pixels`` (flat indices), their working values and noise."""
    height, width = mask.shape
    bins_high, bins_wide = -(-height // ERROR_BIN), -(-width // ERROR_BIN)
    rows, columns = np.divmod(pixels, width)
    index = (rows // ERROR_BIN) * bins_wide + columns // ERROR_BIN
    # per bin: the traced count, the sum of values, the sum of squares less their noise; then over the
    # window. Each plane float32 and on its own (64 KB at 256x256; a float64 stack of the three and its
    # padded copies were 400-KB temporaries, fresh pages in a render); the values centred first, so
    # their squares keep their digits in float32
    values = values - np.float32(values.mean()) if values.size else values
    bins = bins_high * bins_wide
    count, total, excess_total = (_window_sums(np.bincount(index, weights, bins).astype(np.float32)
                                               .reshape(bins_high, bins_wide), ERROR_WINDOW)
                                  for weights in (None, values, values * values - noise))
    safe = np.maximum(count, np.float32(1.0))
    local_mean = total / safe
    excess = excess_total / safe
    excess -= local_mean * local_mean
    np.maximum(excess, np.float32(0.0), out=excess)
    excess[count <= 1] = 0.0
    weight = upsampled(_capped_weight(np.sqrt(excess, out=excess)), ERROR_BIN, height, width)
    weight += edges_density
    weight += 1.0
    density = _normalise(weight, floor)
    density[mask] = 0.0
    density *= 1.0 / max(float(density.mean()), 1e-30)
    return density


def error_density(radiance: np.ndarray, variance: np.ndarray, mask: np.ndarray, albedo: np.ndarray,
                  coverage: np.ndarray | None, edges_density: np.ndarray, floor: float = FLOOR) -> np.ndarray:
    """(H, W) float32 density of the second pass of ``two_pass``, mean 1, 0 on traced pixels.

    A cheap stand-in for the completion's error, from the first pass alone: the spread of the traced
    samples about their mean over a window of ``ERROR_WINDOW`` x ``ERROR_WINDOW`` bins of
    ``ERROR_BIN`` x ``ERROR_BIN`` pixels, less the part their own noise explains, given to every pixel
    of the window's centre bin; the feature density ``edges_density`` is added so a region the first
    pass barely sampled is not judged smooth by default. Only the traced pixels are read.

    Parameters
    ----------
    radiance : (H, W, 3) linear radiance of the first pass (any value on untraced pixels).
    variance : (H, W) variance of each traced pixel's mean.
    mask : (H, W) bool, the first pass's traced pixels.
    albedo, coverage : the feature buffers (coverage None: from ``albedo``).
    edges_density : (H, W) the first pass's density (:func:`feature_density`).
    floor : share of the density spread evenly, in [0, 1].
    """
    domain = WorkingDomain()
    pixels = np.flatnonzero(mask)
    traced_coverage = None if coverage is None else coverage.ravel()[pixels][None]
    factor = channel_mean(domain.factor(albedo.reshape(-1, 3)[pixels][None], traced_coverage)[0])
    demodulated = channel_mean(radiance.reshape(-1, 3)[pixels]) / factor
    working = domain.scale * np.log1p(demodulated)
    # the delta method's variance of the working value: (scale / (factor + radiance))^2 * variance
    noise = variance.ravel()[pixels] * (domain.scale / (factor * (1.0 + demodulated))) ** 2
    return _disagreement(pixels, working, noise, mask, edges_density, floor)
