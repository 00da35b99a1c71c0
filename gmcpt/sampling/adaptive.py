"""Adaptive path tracing + OIDN: what a Blender Cycles user has, and the strongest baseline of the evaluation.

A first pass traces every pixel at ``first_share`` of the budget (at least 1 spp); the rest goes out in one
step, each pixel's extra samples proportional to a power of its estimated error in the displayed image, at
most ``max_extra`` a pixel, the total exact (``round(budget * W * H)`` path samples); Intel OIDN then denoises
the frame with the feature pass's albedo and normal, the same guides the completion methods' last stage gets.
The passes are the masked integrator's own (:func:`gmcpt.render.kernels.trace_counts`), so its time is real.

A first pass of 1 spp with the rest placed by relative error (the recipe issue 40 started from) beat uniform
sampling on the synthetic scenes but lost 1-3 dB on the real interiors, where OIDN gets most pixels at 1 spp
of fireflies and dim indirect light; a larger uniform first pass and the error of the tonemapped image fixed
that (docs/experiments.md). Rounds that re-estimate each pixel's error from its own samples (as Cycles
does) did worse than uniform sampling when the baseline was specified.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import GmcptError
from ..frame import DEFAULT_FEATURE_SPP
from ..limits import SEED_LIMIT, check_feature_spp, check_seed, check_spp
from ..seeds import EXTRA_SEED_OFFSET

#: the largest budget (mean samples a pixel) of the baseline: the evaluation's largest is 32
MAX_BUDGET = 64

#: the second pass's sampler seeds differ from the first's
#: the recipe (docs/experiments.md): a uniform first pass of 5/8 of the budget, extra samples ~ error^0.5, 32 at most
FIRST_SHARE = 0.625
MAX_EXTRA = 32
EXPONENT = 0.5


@dataclass(frozen=True)
class AdaptiveSettings:
    """What :func:`render_adaptive` traces.

    Attributes
    ----------
    budget : mean path samples per pixel, in [1, :data:`MAX_BUDGET`].
    seed : sampler seed (the second pass uses ``seed + EXTRA_SEED_OFFSET``).
    first_share : the first pass traces every pixel at ``max(1, floor(first_share * budget))`` spp.
    max_extra : most extra samples one pixel gets.
    exponent : extra samples follow ``error ** exponent``.
    feature_spp : primary samples per pixel of the feature pass (OIDN's guides).
    """

    budget: float
    seed: int = 0
    first_share: float = FIRST_SHARE
    max_extra: int = MAX_EXTRA
    exponent: float = EXPONENT
    feature_spp: int = DEFAULT_FEATURE_SPP

    def __post_init__(self):
        check_seed(self.seed)
        check_spp(self.max_extra, "max_extra")
        check_feature_spp(self.feature_spp)
        budget = float(self.budget)
        if not math.isfinite(budget) or not 1 <= budget <= MAX_BUDGET:
            raise GmcptError(f"adaptive budget must be in [1, {MAX_BUDGET}] samples per pixel, got {self.budget}")
        if not 0 <= self.first_share <= 1:
            raise GmcptError(f"adaptive first_share must be in [0, 1], got {self.first_share}")
        if not math.isfinite(self.exponent) or self.exponent < 0:
            raise GmcptError(f"adaptive exponent must be >= 0, got {self.exponent}")
        if budget - self.first_spp > self.max_extra:
            raise GmcptError(f"adaptive budget {budget} leaves more than max_extra {self.max_extra} extra samples "
                             "a pixel after the first pass")

    @property
    def first_spp(self) -> int:
        """Samples of every pixel in the first pass."""
        return max(1, int(self.first_share * self.budget))


@dataclass(frozen=True, eq=False)
class AdaptiveInfo:
    """What :func:`render_adaptive` traced (no sidecar records it; compared by identity: ``samples`` is an array).

    Attributes
    ----------
    budget : the mean path samples a pixel it was given (:attr:`AdaptiveSettings.budget`).
    path_samples : samples traced, both passes: exactly ``round(budget * W * H)``.
    samples : (H, W) int64, the samples each pixel got.
    nonfinite_samples : those that were NaN/Inf (left out of the image).
    """

    budget: float
    path_samples: int
    samples: np.ndarray
    nonfinite_samples: int


def _box3(plane: np.ndarray) -> np.ndarray:
    """3x3 mean with edge replication."""
    padded = np.pad(plane, 1, mode="edge")
    height, width = plane.shape
    total = np.zeros_like(plane)
    for dy in range(3):
        for dx in range(3):
            total += padded[dy:dy + height, dx:dx + width]
    return total / 9


def display_error(image: np.ndarray) -> np.ndarray:
    """(H, W) estimate of each pixel's squared error in the displayed image, from a noisy (H, W, 3) one: the
    variance of the tonemapped luminance (:func:`gmcpt.image.metrics.tonemap`) over its 3x3 neighbourhood, smoothed
    over 3x3 again.

    A pixel's own few samples say little of its variance; its neighbours' spread stands in for it (and also
    counts edges, where a denoiser needs samples too). Measured in the displayed image, a firefly counts for
    no more than a white pixel, so it does not draw the budget as it does in linear radiance.
    """
    from ..image.metrics import tonemap

    luminance = tonemap(image).mean(axis=-1, dtype=np.float64)
    mean = _box3(luminance)
    return _box3(np.maximum(_box3(luminance * luminance) - mean * mean, 0.0))


def allocate(weights: np.ndarray, total: int, cap: int) -> np.ndarray:
    """Integer extra samples a pixel, proportional to ``weights``, at most ``cap`` each, summing to ``total``.

    Pixels above the cap are clipped and the rest shared again among the others, until none is above;
    the rounding remainder goes to the largest fractional parts (ties to the lower pixel index), so the
    result is a pure function of the inputs.
    """
    weights = np.asarray(weights, np.float64).ravel()
    if total < 0 or total > cap * weights.size:
        raise GmcptError(f"cannot place {total} samples on {weights.size} pixels at most {cap} each")
    weights = np.where(np.isfinite(weights) & (weights > 0), weights, 0.0)
    if weights.sum() <= 0:
        weights = np.ones_like(weights)
    ideal = np.zeros_like(weights)
    free = np.ones(weights.size, bool)
    left = float(total)
    while left > 0 and free.any():
        share = weights * free
        if share.sum() <= 0:  # only zero-weight pixels left free: spread what is left evenly over them
            share = free.astype(np.float64)
        ideal = np.where(free, left * share / share.sum(), ideal)
        over = free & (ideal >= cap)
        if not over.any():
            break
        ideal[over] = cap
        free &= ~over
        left = total - ideal[~free].sum()
    counts = np.minimum(np.floor(ideal + 1e-9), cap).astype(np.int64)
    remainder = int(total - counts.sum())
    if remainder > 0:  # to the largest fractions, ties to the lower pixel index (a partition, not a sort: 5x faster)
        fraction = np.where(counts < cap, ideal - counts, -1.0)
        last = np.partition(fraction, fraction.size - remainder)[fraction.size - remainder]
        above = np.flatnonzero(fraction > last)
        counts[above] += 1
        counts[np.flatnonzero(fraction == last)[:remainder - above.size]] += 1
    return counts


def render_adaptive(scene, integrator, settings: AdaptiveSettings, sensor=None,
                    features: dict | None = None, guide_rays: int = 0) -> tuple[np.ndarray, AdaptiveInfo, dict]:
    """Adaptive path tracing + OIDN (``features``: OIDN's guides, the mean of ``guide_rays`` primary rays a
    pixel; by default a feature pass of ``settings.feature_spp``).

    Returns ``(image (H, W, 3) float32, info, timings)``: ``info`` (:class:`AdaptiveInfo`) has ``path_samples``
    (exactly ``round(budget * W * H)``), ``samples`` (the (H, W) count map) and ``nonfinite_samples``; ``timings`` has
    ``features_s`` (0 when ``features`` are given), ``render_s`` (both passes), ``placement_s`` and
    ``denoise_s``.
    """
    from ..image.denoise import denoise_oidn
    from ..render.kernels import render_features, sensor_film_size, trace_counts
    from ..render.scene import scene_sensor

    sensor = sensor if sensor is not None else scene_sensor(scene)
    height, width = sensor_film_size(sensor)
    pixels = height * width
    timings = {"features_s": 0.0}
    if features is None:
        start = time.perf_counter()
        features, guide_rays = render_features(scene, sensor, settings.feature_spp, settings.seed), settings.feature_spp
        timings["features_s"] = time.perf_counter() - start

    start = time.perf_counter()
    first = np.full(pixels, settings.first_spp, np.int64)
    total, _, finite = trace_counts(scene, sensor, integrator, first, settings.seed)
    timings["render_s"] = time.perf_counter() - start

    start = time.perf_counter()
    image = (total / np.maximum(finite, 1)[:, None]).reshape(height, width, 3)
    extra_total = int(round(settings.budget * pixels)) - int(first.sum())
    extra = allocate(display_error(image) ** settings.exponent, extra_total, settings.max_extra)
    timings["placement_s"] = time.perf_counter() - start

    start = time.perf_counter()
    if extra_total > 0:
        more, _, more_finite = trace_counts(scene, sensor, integrator, extra,
                                          (settings.seed + EXTRA_SEED_OFFSET) % SEED_LIMIT)
        total, finite = total + more, finite + more_finite
    timings["render_s"] += time.perf_counter() - start
    image = (total / np.maximum(finite, 1)[:, None]).reshape(height, width, 3).astype(np.float32)

    start = time.perf_counter()
    denoised = denoise_oidn(image, features["albedo"], features["normal"], guide_rays)
    timings["denoise_s"] = time.perf_counter() - start
    samples = (first + extra).reshape(height, width)
    info = AdaptiveInfo(budget=settings.budget, path_samples=int(samples.sum()), samples=samples,
                        nonfinite_samples=int(samples.sum() - finite.sum()))
    return denoised, info, timings
