"""Render a sparse frame: dense feature buffers + path tracing of masked pixels.

The radiance pass builds its ray batch from the *compacted* list of traced
pixels (``n_traced * spp`` lanes), so its cost scales with the sampling rate.
Lane ``k * spp + s`` is sample ``s`` of the ``k``-th traced pixel, and the
sampler is seeded for exactly that many lanes, drawing in the same order as
Mitsuba's own ``SamplingIntegrator``: at rate 1 the samples, and so the image,
equal the stock integrator's for the same seed.

Each pixel's value is the box-filter estimate (plain mean of its samples);
non-finite samples are left out of the mean and counted. The variance of the
mean is kept alongside. Sums are accumulated inside the one path tracing
kernel (``scatter_reduce``), so no per-sample buffer is written.

The feature pass traces ``feature_spp`` primary rays per pixel, all pixels,
and records albedo, shading normal, depth and light visibility (one shadow ray
towards a sampled emitter point per primary ray).
"""
from __future__ import annotations

import hashlib
import sys
import time
from dataclasses import dataclass, replace
from typing import Callable

import drjit as dr
import mitsuba as mi
import numpy as np

from .budget import (PROBE_SPP, SPARSE, SPARSE_SPP, check_budget, choose, edge_share, even_fill, plan_budget,
                     relative_variance)
from .domain import ALBEDO_MIN
from .errors import GmcptError
from .frame import DEFAULT_FEATURE_SPP, SparseFrame  # noqa: F401  (DEFAULT_FEATURE_SPP re-exported)
from .limits import SEED_LIMIT, check_feature_spp, check_resolution, check_seed, check_spp
from .masks import (DEFAULT_PATTERN, DEFAULT_RATE, FEATURE_PATTERNS, check_pattern, check_rate, make_mask, mask_rng,
                    sample_by_density, sample_count, second_pass_mask)
from .placement import FIRST_PASS_SHARE, error_density, feature_density
from .scene import scene_sensor

MAX_LANES = 1 << 24  # split the radiance pass into several when larger
FEATURE_SEED_OFFSET = 0x5EED_F00D
SECOND_PASS_SEED_OFFSET = 0x2BA55  # the second radiance pass of ``two_pass`` draws other samples
TOP_UP_SEED_OFFSET = 0x70B0F  # and a budget's first-pass pixels their samples after the choice
EVEN_SEED_OFFSET = 0xE7E4  # the dense way's blue-noise spread of the samples left over
# samples of a pixel are consecutive lanes: pre-reduce them within a SIMD packet, one atomic per packet
SCATTER_MODE = dr.ReduceMode.Local
# the features need UVs (textured albedo) and the shading frame, no surface derivatives
FEATURE_RAY_FLAGS = mi.RayFlags.Minimal | mi.RayFlags.UV | mi.RayFlags.ShadingFrame
#: the frozen kernels (dr.freeze) keep the recordings of the last few resolutions and spp of a scene; a new
#: one records again, as expected: no warning about it
FREEZE_OPTIONS = {"limit": 8, "warn_after": 1 << 30}


class FrozenKernel:
    """``function(scene, ...)`` recorded by ``dr.freeze`` once per scene and settings, then replayed.

    Each scene gets recordings of its own: replaying one scene's recording for another scene of the
    same layout read the first scene's freed objects (a batch that loads the scene again for every
    frame got garbage features now and then). :data:`_SCENES` holds each scene beside its recordings, so
    no other scene can take its ``id`` while they live; both are let go at the first call after nobody
    else holds the scene. Dr.Jit cannot record a virtual call when objects of another live scene share
    the call's registry (seen with the breakfast room loaded beside another scene): the recording
    raises, and that scene runs the plain function, with the same result. Call with a function that
    builds the arguments, so a failed recording leaves none dirty.
    """

    def __init__(self, function: Callable):
        self.function = function

    def __call__(self, scene: mi.Scene, arguments: Callable[[], tuple]):
        _let_go_of_released_scenes()
        recordings = _SCENES.setdefault(id(scene), (scene, {}))[1]
        if self not in recordings:
            recordings[self] = dr.freeze(self.function, **FREEZE_OPTIONS)
        if recordings[self] is not None:
            try:
                return recordings[self](scene, *arguments())
            except RuntimeError:
                recordings[self] = None
        outputs = self.function(scene, *arguments())
        dr.eval(outputs)  # one kernel for all of them, as a replay gives (else one kernel a column read)
        return outputs


#: id -> (scene, {kernel: its recordings, or None where Dr.Jit refused to record}) of the scenes traced so far
_SCENES: dict[int, tuple[mi.Scene, dict]] = {}


def _let_go_of_released_scenes() -> None:
    """Drop the scenes that only :data:`_SCENES` holds (``sys.getrefcount``: its tuple and the argument)."""
    for key in [key for key in _SCENES if sys.getrefcount(_SCENES[key][0]) <= 2]:
        del _SCENES[key]


@dataclass(frozen=True)
class RenderSettings:
    """What to trace. ``spp=0`` keeps the sensor's sample count. A ``budget`` (mean path samples a pixel, 0: none)
    replaces ``rate`` and ``spp``: :mod:`gmcpt.budget` chooses them per frame, with the ``two_pass`` mask.

    Checked when made (:mod:`gmcpt.limits`): a bad value raises a one-line :class:`~gmcpt.errors.GmcptError`.
    """

    rate: float = DEFAULT_RATE
    pattern: str = DEFAULT_PATTERN
    seed: int = 0
    spp: int = 0
    feature_spp: int = DEFAULT_FEATURE_SPP
    budget: float = 0.0

    def __post_init__(self):
        check_rate(self.rate)
        check_pattern(self.pattern)
        check_seed(self.seed)
        if self.spp != 0:
            check_spp(self.spp)
        check_feature_spp(self.feature_spp)
        if self.budget:
            check_budget(self.budget)
            if self.spp:
                raise GmcptError("a budget sets the samples per pixel itself: give a budget or spp, not both")
            if self.pattern != "two_pass":
                raise GmcptError(f"a budget places its samples with the two_pass mask, not {self.pattern!r}")


def pass_seed(seed: int, index: int, passes: int) -> int:
    """The sampler seed of radiance pass ``index`` of ``passes``: ``seed`` itself when there is one pass,
    else a 32-bit hash of (seed, index), which stays in range for every seed."""
    if passes == 1:
        return seed
    return int.from_bytes(hashlib.blake2b(f"{seed}/{index}".encode(), digest_size=4).digest(), "little")


def _sensor_film_size(sensor: mi.Sensor) -> tuple[int, int]:
    size = sensor.film().crop_size()
    return int(size[1]), int(size[0])


def _primary_rays(sensor: mi.Sensor, sampler: mi.Sampler, pixel: mi.UInt32, width: int,
                  spp: int) -> tuple[mi.RayDifferential3f, mi.Color3f]:
    """Rays through ``pixel`` (flat index per lane), drawn as Mitsuba's integrators do."""
    film = sensor.film()
    pos = mi.Vector2u(pixel % width, pixel // width) + mi.Vector2u(film.crop_offset())
    pos_f = mi.Vector2f(pos) + sampler.next_2d()
    scale = dr.rcp(mi.ScalarVector2f(film.crop_size()))
    offset = -mi.ScalarVector2f(film.crop_offset()) * scale
    aperture = sampler.next_2d() if sensor.needs_aperture_sample() else mi.Point2f(0.5)
    ray_time = mi.Float(sensor.shutter_open())
    if sensor.shutter_open_time() > 0:
        ray_time += sampler.next_1d() * sensor.shutter_open_time()
    ray, weight = sensor.sample_ray_differential(time=ray_time, sample1=0.0,
                                                 sample2=dr.fma(pos_f, scale, offset), sample3=aperture)
    ray.scale_differential(dr.rsqrt(float(spp)))
    return ray, weight


def _seeded_sampler(sensor: mi.Sensor, spp: int, seed: int | mi.UInt32, lanes: int) -> mi.Sampler:
    sampler = sensor.sampler().clone()
    sampler.set_sample_count(spp)
    sampler.set_samples_per_wavefront(spp)
    sampler.seed(seed, lanes)
    return sampler


def _feature_means(scene: mi.Scene, sensor: mi.Sensor, seed: mi.UInt32, feature_spp: int, camera: tuple) -> list:
    """Per-pixel means of albedo (3), normal (3), hit distance, visibility, hit fraction and coverage over
    ``feature_spp`` primary rays (see :func:`render_features`); ``camera`` (:func:`_camera_key`) keys the
    recording of :data:`_frozen_feature_means`."""
    width, height = camera[0]
    lanes = height * width * feature_spp
    sampler = _seeded_sampler(sensor, feature_spp, seed, lanes)
    pixel = dr.arange(mi.UInt32, lanes) // feature_spp
    ray, _ = _primary_rays(sensor, sampler, pixel, width, feature_spp)
    si = scene.ray_intersect(ray, FEATURE_RAY_FLAGS, True)
    hit = si.is_valid()
    bsdf = si.bsdf(ray)
    diffuse = hit & mi.has_flag(bsdf.flags(), mi.BSDFFlags.DiffuseReflection)
    albedo = dr.select(diffuse, dr.clip(bsdf.eval_diffuse_reflectance(si, diffuse), 0.0, 1.0), 0.0)
    covered = dr.select(dr.max(albedo) >= ALBEDO_MIN, 1.0, 0.0)
    normal = dr.select(hit, si.sh_frame.n, 0.0)
    distance = dr.select(hit, si.t, 0.0)
    _, emitter_weight = scene.sample_emitter_direction(si, sampler.next_2d(), True, hit)
    visible = dr.select(hit & ((emitter_weight[0] + emitter_weight[1] + emitter_weight[2]) > 0), 1.0, 0.0)
    hit_weight = dr.select(hit, 1.0, 0.0)
    # Average each pixel's samples inside the kernel (as trace_pixels sums its radiance): one value per
    # pixel comes back. Measured on 256x256 at 4 spp: 0.035-0.045 s instead of 0.055-0.06 s with a
    # numpy mean over per-sample buffers.
    values = [*albedo, *normal, distance, visible, hit_weight, covered]
    if feature_spp > 1:
        means = [dr.zeros(mi.Float, height * width) for _ in values]
        for target, value in zip(means, values):
            dr.scatter_reduce(dr.ReduceOp.Add, target, value / feature_spp, pixel, mode=SCATTER_MODE)
        values = means
    return values


#: :func:`_feature_means` recorded once per scene, resolution and feature spp, then replayed (as the radiance pass)
_frozen_feature_means = FrozenKernel(_feature_means)


def render_features(scene: mi.Scene, sensor: mi.Sensor, feature_spp: int = DEFAULT_FEATURE_SPP, seed: int = 0) -> dict:
    """Albedo, shading normal, depth and visibility for every pixel.

    Returns a dict of float32 arrays: ``albedo`` and ``normal`` (H, W, 3),
    ``depth``, ``visibility`` and ``coverage`` (H, W).

    ``albedo`` is the diffuse reflectance of BSDFs that have a diffuse lobe,
    clipped to [0, 1], and 0 for the others: Mitsuba's default
    ``eval_diffuse_reflectance`` (the BSDF times pi at normal incidence) gives
    a rough metal an "albedo" of 5 to 70 where its highlight faces the camera.
    ``coverage`` is the fraction of the pixel's rays whose albedo is at least
    :data:`~gmcpt.domain.ALBEDO_MIN` (the rays that demodulation divides).
    """
    height, width = _sensor_film_size(sensor)
    feature_seed = (seed + FEATURE_SEED_OFFSET) % SEED_LIMIT
    values = _frozen_feature_means(scene, lambda: (sensor, dr.opaque(mi.UInt32, feature_seed), feature_spp,
                                                   _camera_key(sensor)))
    columns = [np.asarray(value, dtype=np.float32).reshape(height, width) for value in values]
    albedo, normal = np.stack(columns[0:3], axis=-1), _unit_normals(columns[3:6], feature_spp)
    distance, visible, hit_fraction, coverage = columns[6:]
    distance = distance / np.maximum(hit_fraction, 1e-6)
    max_distance = float(distance.max()) if (hit_fraction > 0).any() else 1.0
    depth = np.where(hit_fraction > 0, distance / max(max_distance, 1e-12), 1.0)
    return {"albedo": albedo, "normal": normal, "depth": depth.astype(np.float32), "visibility": visible,
            "coverage": coverage}


def _unit_normals(planes: list, feature_spp: int) -> np.ndarray:
    """(H, W, 3) normals from their three (H, W) float32 planes of per-pixel means: a mean of unit normals
    is renormalised (one sample is unit already, or 0 on a miss). Worked plane by plane: a norm over the
    short last axis of an (H, W, 3) array takes ten times as long (256x256: 2.1 ms against 0.2 ms)."""
    if feature_spp == 1:
        return np.stack(planes, axis=-1)
    length = planes[0] * planes[0]
    for plane in planes[1:]:
        length += plane * plane
    np.sqrt(length, out=length)
    np.maximum(length, np.float32(1e-6), out=length)
    normal = np.empty((*length.shape, 3), np.float32)
    for channel, plane in enumerate(planes):
        np.divide(plane, length, out=normal[..., channel])
    return normal


def _camera_key(sensor: mi.Sensor) -> tuple:
    """The sensor's scalar settings that :func:`_primary_rays` bakes into a kernel as constants."""
    film = sensor.film()
    return (tuple(film.crop_size()), tuple(film.crop_offset()), sensor.shutter_open(), sensor.shutter_open_time(),
            sensor.needs_aperture_sample())


def _pixel_sums(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, pixels: mi.UInt32,
                lane: mi.UInt32, seed: mi.UInt32, spp: int, camera: tuple, sums: list) -> list:
    """Path trace lane ``k * spp + s`` (``lane`` counts them) as sample ``s`` of pixel ``pixels[k]`` and add
    (R, G, B, squared norm, finite count) of the finite samples to ``sums`` (five zero arrays, one value a pixel).

    Every size comes from an argument's width, so :data:`_frozen_pixel_sums` replays its kernel for any
    pixel count; ``camera`` (:func:`_camera_key`) only keys the recording.
    """
    sampler = _seeded_sampler(sensor, spp, seed, dr.width(lane))
    lane_pixel = lane // spp
    ray, weight = _primary_rays(sensor, sampler, dr.gather(mi.UInt32, pixels, lane_pixel), camera[0][0], spp)
    radiance, _, _ = integrator.sample(scene, sampler, ray, sensor.get_medium(), True)
    radiance = weight * radiance
    finite = dr.isfinite(radiance[0]) & dr.isfinite(radiance[1]) & dr.isfinite(radiance[2])
    radiance = dr.select(finite, radiance, 0.0)
    # Accumulate per pixel inside the path tracing kernel (as the film does,
    # with as many channels: RGB, squared norm, count of finite samples).
    values = [radiance[0], radiance[1], radiance[2], dr.squared_norm(radiance), dr.select(finite, 1.0, 0.0)]
    for target, value in zip(sums, values):
        dr.scatter_reduce(dr.ReduceOp.Add, target, value, lane_pixel, mode=SCATTER_MODE)
    return sums


#: :func:`_pixel_sums` recorded once per scene, integrator, spp and camera, then replayed: tracing the path
#: integrator's kernel in Python costs about 10 ms a pass (a tenth of that replayed), as much as 2 % of a
#: cheap 16-spp frame. A recording costs about what one plain trace does.
_frozen_pixel_sums = FrozenKernel(_pixel_sums)


def trace_pixels(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator,
                 pixels: np.ndarray, spp: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Path trace ``spp`` samples for each flat pixel index in ``pixels``.

    Returns float32 ``(sum, sum_of_squares, count)`` over the finite samples,
    shapes (n, 3), (n,) and (n,); the sum of squares is summed over the three
    channels (all that the channel-averaged variance needs).
    """
    # opaque zeros and seed: literals that change between calls would make the frozen function record again
    sums = _frozen_pixel_sums(scene, lambda: (sensor, integrator, mi.UInt32(pixels.astype(np.uint32)),
                                              dr.arange(mi.UInt32, pixels.size * spp), dr.opaque(mi.UInt32, seed),
                                              spp, _camera_key(sensor),
                                              [dr.opaque(mi.Float, 0.0, pixels.size) for _ in range(5)]))
    red, green, blue, squares, count = (np.asarray(column) for column in sums)
    return np.stack([red, green, blue], axis=1), squares, count


def _trace_mean(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, pixels: np.ndarray,
                spp: int, seed: int, say: Callable[[str], None]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Box estimate of each pixel in ``pixels``: (mean (n, 3), variance of the mean (n,), finite sample count (n,)).

    Split into several kernel launches of at most :data:`MAX_LANES` lanes (:func:`_mean_and_variance`).
    """
    if pixels.size == 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    passes = max(1, -(-pixels.size * spp // MAX_LANES))
    pass_spp = -(-spp // passes)
    total, squares, count, done = 0.0, 0.0, 0.0, 0
    for index in range(passes):
        this_spp = min(pass_spp, spp - done)
        if this_spp <= 0:
            break
        say(f"path tracing: {pixels.size} px x {spp} spp"
            + (f" (pass {index + 1}/{passes})" if passes > 1 else ""))
        s, q, n = trace_pixels(scene, sensor, integrator, pixels, this_spp, pass_seed(seed, index, passes))
        total, squares, count, done = total + s, squares + q, count + n, done + this_spp
    mean, variance_of_mean = _mean_and_variance(total, squares, count)
    return mean, variance_of_mean, count


def _first_mask(settings: RenderSettings, features: dict, height: int, width: int) -> tuple[np.ndarray, np.ndarray]:
    """The mask of the (first) radiance pass, and the feature density (None for the patterns without one, and at rate 1)."""
    count = sample_count(settings.rate, height * width)
    if count == height * width:  # at rate 1 there is nothing to place (and no density to compute)
        return np.ones((height, width), bool), None
    if settings.pattern not in FEATURE_PATTERNS:
        return make_mask(height, width, settings.rate, settings.pattern, settings.seed), None
    density = feature_density(features["albedo"], features["normal"], features["depth"], features["visibility"],
                              features["coverage"])
    if settings.pattern == "adaptive":
        return make_mask(height, width, settings.rate, "adaptive", settings.seed, density), density
    first = max(1, int(round(count * FIRST_PASS_SHARE)))
    return sample_by_density(density, first, mask_rng(settings.seed)), density


def trace_counts(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, counts: np.ndarray,
                 seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trace ``counts[p]`` samples of each flat pixel ``p``: (sum (N, 3), sum of squared norms (N,), finite sample
    count (N,)), float64.

    Each sample is one lane of a 1-spp pass over the pixel list with repeats, split into parts of at most
    :data:`MAX_LANES` lanes with a seed of its own per part.
    """
    pixels = np.repeat(np.arange(counts.size), counts)
    total, squares, finite = np.zeros((counts.size, 3)), np.zeros(counts.size), np.zeros(counts.size)
    parts = max(1, -(-pixels.size // MAX_LANES))
    for index, chunk in enumerate(np.array_split(pixels, parts)):
        if chunk.size == 0:
            continue
        sums, chunk_squares, count = trace_pixels(scene, sensor, integrator, chunk, 1, pass_seed(seed, index, parts))
        for channel in range(3):
            total[:, channel] += np.bincount(chunk, weights=sums[:, channel], minlength=counts.size)
        squares += np.bincount(chunk, weights=chunk_squares, minlength=counts.size)
        finite += np.bincount(chunk, weights=count, minlength=counts.size)
    return total, squares, finite


def _mean_and_variance(total: np.ndarray, squares: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Box estimate (n, 3) and the variance of that mean (n,), channel-averaged unbiased, in float64 (sum of
    squares minus n mean^2 cancels)."""
    inverse_count = 1.0 / np.maximum(count, 1)
    mean = total * inverse_count[:, None]
    sample_variance = (squares - count * np.einsum("ij,ij->i", mean, mean, dtype=np.float64)) \
        / (3 * np.maximum(count - 1, 1))
    return mean, np.maximum(sample_variance, 0.0) * inverse_count


@dataclass
class _Passes:
    """What the radiance passes left: flat (H*W) buffers and counts."""

    radiance: np.ndarray  # (N, 3) float32, 0 where untraced
    variance: np.ndarray  # (N,) float32 variance of each mean
    traced: np.ndarray  # (N,) bool, before the pixels without a finite sample are dropped
    finite: np.ndarray  # (N,) finite samples a pixel
    path_samples: int
    first_pass_pixels: int
    info: dict


def _mask_passes(scene, sensor, integrator, settings: RenderSettings, features: dict, mask: np.ndarray | None,
                 spp: int, say, timings: dict) -> _Passes:
    """The passes at a fixed rate: the mask's pixels at ``spp``, and for ``two_pass`` a second pass."""
    height, width = features["depth"].shape
    start = time.perf_counter()
    density = None
    if mask is None:
        mask, density = _first_mask(settings, features, height, width)
    timings["mask_s"] = time.perf_counter() - start

    start = time.perf_counter()
    pixels = np.flatnonzero(mask)
    mean, variance_of_mean, count = _trace_mean(scene, sensor, integrator, pixels, spp, settings.seed, say)
    timings["render_s"] = time.perf_counter() - start
    passes = _Passes(np.zeros((height * width, 3), np.float32), np.zeros(height * width, np.float32),
                     mask.ravel().copy(), np.zeros(height * width), pixels.size * spp, pixels.size, {})
    _store(passes, pixels, mean, variance_of_mean, count)
    rest = sample_count(settings.rate, height * width) - pixels.size
    if settings.pattern == "two_pass" and density is not None and rest > 0:
        _second_pass(scene, sensor, integrator, settings, features, density, rest, spp, passes, say, timings)
    return passes


def _store(passes: _Passes, pixels: np.ndarray, mean: np.ndarray, variance_of_mean: np.ndarray,
           count: np.ndarray) -> None:
    """Write the estimates of ``pixels`` into ``passes`` (a pixel without a finite sample keeps zeros)."""
    valid = count > 0
    passes.radiance[pixels] = np.where(valid[:, None], mean, 0.0)
    passes.variance[pixels] = np.where(valid, variance_of_mean, 0.0)
    passes.finite[pixels] = count
    passes.traced[pixels] = True


def _second_pass(scene, sensor, integrator, settings: RenderSettings, features: dict, density: np.ndarray,
                 rest: int, spp: int, passes: _Passes, say, timings: dict) -> None:
    """The second pass of ``two_pass``: ``rest`` more pixels where the first pass's samples disagree."""
    height, width = features["depth"].shape
    start = time.perf_counter()
    first = passes.traced.reshape(height, width)
    errors = error_density(passes.radiance.reshape(height, width, 3), passes.variance.reshape(height, width), first,
                           features["albedo"], features["coverage"], density)
    second = np.flatnonzero(second_pass_mask(errors, rest, first, settings.seed))
    timings["mask_s"] += time.perf_counter() - start
    start = time.perf_counter()
    mean, variance_of_mean, count = _trace_mean(scene, sensor, integrator, second, spp,
                                                (settings.seed + SECOND_PASS_SEED_OFFSET) % SEED_LIMIT, say)
    timings["render_s"] += time.perf_counter() - start
    _store(passes, second, mean, variance_of_mean, count)
    passes.path_samples += second.size * spp


def _budget_passes(scene, sensor, integrator, settings: RenderSettings, features: dict, plan, say,
                   timings: dict) -> _Passes:
    """The passes of a budget (:mod:`gmcpt.budget`): a first pass at ``PROBE_SPP``, then the sparse way (its
    pixels topped up to ``SPARSE_SPP``, the second pass of ``two_pass``) or the dense one (every pixel, as
    evenly as integers allow)."""
    height, width = features["depth"].shape
    pixels = height * width
    seed = settings.seed
    # the sparse way's settings: its first pass is the budget's, placed as two_pass places its own
    sparse = replace(settings, rate=plan.sparse_rate, budget=0.0)
    start = time.perf_counter()
    first, density = np.zeros(pixels, bool), None
    if not plan.dense_only:
        first, density = _first_mask(sparse, features, height, width)
        first = first.ravel()
    timings["mask_s"] = time.perf_counter() - start

    sums = _Sums(pixels)
    start = time.perf_counter()
    say(f"path tracing: {int(first.sum())} px x {PROBE_SPP} spp (first pass)")
    sums.trace(scene, sensor, integrator, first * PROBE_SPP, seed)
    timings["render_s"] = time.perf_counter() - start
    mean, variance_of_mean = sums.estimate(first)
    statistic = relative_variance(mean, variance_of_mean, PROBE_SPP) if first.any() else None
    edges = edge_share(features) if first.any() else None
    choice = choose(plan, statistic or 0.0, edges or 0.0)
    info = {"budget": plan.budget, "budget_choice": choice, "relative_variance": statistic, "edge_share": edges}
    say(f"budget {plan.budget:g} spp: {choice}"
        + ("" if statistic is None else f" (relative variance {statistic:.3f}, edge share {edges:.2f})"))

    if choice == SPARSE:
        start = time.perf_counter()
        say(f"path tracing: {int(first.sum())} px x {SPARSE_SPP - PROBE_SPP} spp (first pass, the rest)")
        sums.trace(scene, sensor, integrator, first * (SPARSE_SPP - PROBE_SPP), (seed + TOP_UP_SEED_OFFSET) % SEED_LIMIT)
        timings["render_s"] += time.perf_counter() - start
        passes = sums.passes(first, int(first.sum()), info)
        _second_pass(scene, sensor, integrator, sparse, features, density, plan.sparse_pixels - int(first.sum()),
                     SPARSE_SPP, passes, say, timings)
        return passes

    start = time.perf_counter()
    more = even_fill((first * PROBE_SPP).reshape(height, width), plan.samples - int(first.sum()) * PROBE_SPP,
                     (seed + EVEN_SEED_OFFSET) % SEED_LIMIT).ravel()
    timings["mask_s"] += time.perf_counter() - start
    start = time.perf_counter()
    say(f"path tracing: {pixels} px, {int(more.sum())} samples (dense)")
    sums.trace(scene, sensor, integrator, more, (seed + SECOND_PASS_SEED_OFFSET) % SEED_LIMIT)
    timings["render_s"] += time.perf_counter() - start
    return sums.passes(np.ones(pixels, bool), int(first.sum()), info)


class _Sums:
    """Per-pixel sums of samples over several passes (:func:`trace_counts`)."""

    def __init__(self, pixels: int):
        self.total, self.squares, self.finite = np.zeros((pixels, 3)), np.zeros(pixels), np.zeros(pixels)
        self.samples = 0

    def trace(self, scene, sensor, integrator, counts: np.ndarray, seed: int) -> None:
        """Trace ``counts[p]`` more samples of each flat pixel ``p`` and add them."""
        total, squares, finite = trace_counts(scene, sensor, integrator, counts, seed)
        self.total += total
        self.squares += squares
        self.finite += finite
        self.samples += int(counts.sum())

    def estimate(self, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(mean (n, 3), variance of the mean (n,)) of the flat pixels where bool ``pixels``."""
        return _mean_and_variance(self.total[pixels], self.squares[pixels], self.finite[pixels])

    def passes(self, traced: np.ndarray, first_pass_pixels: int, info: dict) -> _Passes:
        mean, variance_of_mean = _mean_and_variance(self.total, self.squares, self.finite)
        valid = traced & (self.finite > 0)
        radiance = np.where(valid[:, None], mean, 0.0).astype(np.float32)
        variance = np.where(valid, variance_of_mean, 0.0).astype(np.float32)
        return _Passes(radiance, variance, traced.copy(), self.finite.copy(), self.samples, first_pass_pixels, info)


def render_sparse_frame(scene: mi.Scene, integrator: mi.SamplingIntegrator, sensor: mi.Sensor | None = None,
                        settings: RenderSettings = RenderSettings(), mask: np.ndarray | None = None,
                        progress: Callable[[str], None] | None = None) -> tuple[SparseFrame, dict]:
    """Render features for all pixels and radiance for the masked ones.

    Parameters
    ----------
    scene : a loaded Mitsuba scene.
    integrator : the integrator that computes radiance per ray (e.g. ``path``).
    sensor : defaults to the scene's first sensor.
    settings : rate, mask pattern, seed, spp, feature spp.
    mask : an explicit (H, W) bool mask; overrides ``settings.rate/pattern``.
    progress : called with a one-line status message before each pass.

    Returns
    -------
    (frame, timings) with timings ``features_s``, ``mask_s`` (placing the samples) and ``render_s``
    (path tracing, both passes of ``two_pass``) in seconds.

    With the ``two_pass`` pattern, a first radiance pass traces ``FIRST_PASS_SHARE`` of the pixel budget
    (``adaptive``), :func:`gmcpt.placement.error_density` reads its samples, and a second pass traces the
    rest of the budget on other pixels, with other sampler seeds. With a ``budget``, the first pass's samples
    choose (:mod:`gmcpt.budget`) between that second pass and a dense one over every untraced pixel; ``info``
    records the choice (``budget_choice``) and its signals (``relative_variance``, ``edge_share``).
    """
    say = progress or (lambda message: None)
    sensor = sensor if sensor is not None else scene_sensor(scene)
    height, width = _sensor_film_size(sensor)
    check_resolution(width, height, settings.feature_spp)
    plan = plan_budget(settings.budget, height * width) if settings.budget and mask is None else None
    spp = SPARSE_SPP if plan is not None else check_spp(settings.spp or sensor.sampler().sample_count())
    timings = {}

    start = time.perf_counter()
    say(f"features: {width}x{height} px x {settings.feature_spp} spp")
    features = render_features(scene, sensor, settings.feature_spp, settings.seed)
    timings["features_s"] = time.perf_counter() - start

    if plan is not None:
        passes = _budget_passes(scene, sensor, integrator, settings, features, plan, say, timings)
    else:
        passes = _mask_passes(scene, sensor, integrator, settings, features, mask, spp, say, timings)

    # pixels whose every sample was NaN/Inf count as untraced
    traced = passes.traced & (passes.finite > 0)
    path_samples = passes.path_samples
    info = {"mask": settings.pattern, "seed": settings.seed, "feature_spp": settings.feature_spp,
            "traced_pixels": int(traced.sum()), "path_samples": int(path_samples),
            "nonfinite_samples": int(path_samples - np.sum(passes.finite)),
            "first_pass_pixels": int(passes.first_pass_pixels), **passes.info}
    frame = SparseFrame(radiance=passes.radiance.reshape(height, width, 3), mask=traced.reshape(height, width),
                        variance=passes.variance.reshape(height, width), spp=spp, info=info, **features)
    return frame, timings
