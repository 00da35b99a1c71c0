"""Where to spend the samples: sampling densities for the ``adaptive`` and ``two_pass`` masks.

Completion errs where the pixels it fills differ from the traced ones around them in ways the
feature buffers do not explain: silhouettes, texture and normal edges, contact and sun shadows,
glossy highlights. A density is an (H, W) array of non-negative weights, mean 1; the masks in
:mod:`gmcpt.masks` turn it into exactly ``round(rate * H * W)`` pixels whose chance of being
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
from scipy import ndimage

from .domain import WorkingDomain, pixel_coverage

#: Share of every density that is spread evenly (the floor): no region is left without samples.
FLOOR = 0.5
#: Edge weight above the floor: ``1 + EDGE_GAIN * min(edge / mean(edge), EDGE_CAP)`` before mixing.
EDGE_GAIN = 4.0
EDGE_CAP = 8.0
#: Extra weight of a pixel whose feature rays saw no diffuse albedo (glass, metal, emitters).
SPECULAR_GAIN = 1.0
#: Fraction of the pixel budget the first pass of ``two_pass`` spends.
FIRST_PASS_SHARE = 0.5
#: Window (pixels) over which a traced sample is compared with its traced neighbours.
ERROR_WINDOW = 7
DEPTH_EPS = 1e-3


def feature_edges(albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray,
                  visibility: np.ndarray) -> np.ndarray:
    """(H, W) float32 edge strength in [0, 1]: the largest difference to a 4-neighbour of any channel of
    albedo, normal (halved), log depth and visibility (clipped to 1), widened by one pixel so both sides
    of an edge count."""
    planes = [*np.moveaxis(albedo, -1, 0), *np.moveaxis(0.5 * normal, -1, 0),
              np.log(np.maximum(depth, DEPTH_EPS)), visibility]
    height, width = depth.shape
    dx = np.zeros((height, width - 1), np.float32)
    dy = np.zeros((height - 1, width), np.float32)
    for plane in planes:  # one channel at a time: a max over a short last axis is ten times slower
        np.maximum(dx, np.abs(plane[:, 1:] - plane[:, :-1]), out=dx)
        np.maximum(dy, np.abs(plane[1:] - plane[:-1]), out=dy)
    edges = np.zeros((height + 2, width + 2), np.float32)  # padded: the widening below needs no bounds checks
    inner = edges[1:-1, 1:-1]
    np.maximum(inner[:, 1:], dx, out=inner[:, 1:])
    np.maximum(inner[:, :-1], dx, out=inner[:, :-1])
    np.maximum(inner[1:], dy, out=inner[1:])
    np.maximum(inner[:-1], dy, out=inner[:-1])
    np.minimum(inner, 1.0, out=inner)
    widened = np.maximum(np.maximum(edges[:, :-2], edges[:, 1:-1]), edges[:, 2:])
    return np.maximum(np.maximum(widened[:-2], widened[1:-1]), widened[2:])


def _normalise(weight: np.ndarray, floor: float) -> np.ndarray:
    """Mix ``weight`` with an even density (``floor`` of the total) and scale the result to mean 1."""
    mean = float(weight.mean())
    shaped = weight / mean if mean > 0 else np.ones_like(weight)
    return (floor + (1.0 - floor) * shaped).astype(np.float32)


def _capped_ratio(values: np.ndarray) -> np.ndarray:
    mean = float(values.mean())
    if mean <= 0:
        return np.zeros_like(values)
    return np.minimum(values / mean, EDGE_CAP)


def feature_density(albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray, visibility: np.ndarray,
                    coverage: np.ndarray | None = None, floor: float = FLOOR) -> np.ndarray:
    """(H, W) float32 sampling density from the feature buffers, mean 1.

    Parameters
    ----------
    albedo, normal : (H, W, 3) feature buffers.
    depth, visibility : (H, W) feature buffers.
    coverage : (H, W) fraction of feature rays with a diffuse albedo (None: from ``albedo``).
    floor : share of the density spread evenly, in [0, 1].
    """
    coverage = pixel_coverage(albedo) if coverage is None else coverage
    edges = _capped_ratio(feature_edges(albedo, normal, depth, visibility))
    weight = 1.0 + EDGE_GAIN * edges + SPECULAR_GAIN * (1.0 - np.clip(coverage, 0.0, 1.0))
    return _normalise(weight, floor)


def _box_sum(values: np.ndarray, size: int) -> np.ndarray:
    return ndimage.uniform_filter(values, size=size, mode="nearest") * (size * size)


def disagreement_density(working: np.ndarray, noise: np.ndarray, mask: np.ndarray, edges_density: np.ndarray,
                         floor: float = FLOOR, window: int = ERROR_WINDOW) -> np.ndarray:
    """(H, W) float32 density of the second pass of ``two_pass``, mean 1, 0 on traced pixels.

    A cheap stand-in for the completion's error, from the first pass alone: each traced sample's
    spread about the mean of the traced samples in a ``window`` around it, less the part their own
    noise explains, counted for every pixel of the window; the feature density ``edges_density`` is
    added so a region the first pass barely sampled is not judged smooth by default.

    Parameters
    ----------
    working : (H, W) traced values in the working domain (demodulated, log-compressed), any value elsewhere.
    noise : (H, W) variance of each traced value in the same domain.
    mask : (H, W) bool, the traced pixels.
    edges_density : (H, W) the first pass's density (:func:`feature_density`).
    """
    traced = mask.astype(np.float32)
    count = _box_sum(traced, window)
    safe = np.maximum(count, 1.0)
    local_mean = _box_sum(working * traced, window) / safe
    local_variance = np.maximum(_box_sum(working * working * traced, window) / safe - local_mean ** 2, 0.0)
    noise_mean = _box_sum(noise * traced, window) / safe
    excess = np.where(count > 1, np.maximum(local_variance - noise_mean, 0.0), 0.0)
    weight = 1.0 + EDGE_GAIN * _capped_ratio(np.sqrt(excess)) + edges_density
    density = _normalise(weight, floor)
    density[mask] = 0.0
    mean = float(density.mean())
    return (density / mean if mean > 0 else density).astype(np.float32)


def _channel_mean(image: np.ndarray) -> np.ndarray:
    """(H, W) mean of an (H, W, 3) image's channels (a sum of planes: a mean over the last axis is slower)."""
    return (image[..., 0] + image[..., 1] + image[..., 2]) / 3.0


def error_density(radiance: np.ndarray, variance: np.ndarray, mask: np.ndarray, albedo: np.ndarray,
                  coverage: np.ndarray | None, edges_density: np.ndarray, floor: float = FLOOR) -> np.ndarray:
    """:func:`disagreement_density` of a first pass's linear radiance (H, W, 3) and variance of the mean (H, W)."""
    domain = WorkingDomain()
    factor = _channel_mean(domain.factor(albedo, coverage))
    demodulated = _channel_mean(radiance) / factor
    working = domain.scale * np.log1p(demodulated)
    # the delta method's variance of the working value: (scale / (factor + radiance))^2 * variance
    noise = variance * (domain.scale / (factor * (1.0 + demodulated))) ** 2
    return disagreement_density(working, np.where(mask, noise, 0.0), mask, edges_density, floor)
