"""The renderer's kernels: feature buffers, path tracing of a pixel list, and Mitsuba's own full frame.

The sampling strategies that call them (fixed rate, two_pass, budget) are in :mod:`gmcpt.sampling.strategies`.

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
and records albedo, shading normal and depth, and where asked light visibility
(one shadow ray towards a sampled emitter point per primary ray: on interiors
with many lights this ray costs several times the rest of the pass).

A dense frame's bulk is Mitsuba's render of every pixel (:func:`render_native`): the
scene's integrator at its full speed, through the frozen pixel-list kernel while the
pass is small and ``mi.render`` above; the pixel-list kernel tops it up.
:func:`render_native_guided` renders it through the integrator's twin
(:mod:`gmcpt.render.guided_path`), whose first hits are the frame's guides.
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import Callable

import drjit as dr
import mitsuba as mi
import numpy as np

from ..errors import GmcptError
from ..frame import DEFAULT_FEATURE_SPP
from ..limits import SEED_LIMIT
from ..seeds import FEATURE_SEED_OFFSET
from .guided_path import FEATURE_PLANES, first_hit_features
from .held import making_room, scene_state

MAX_LANES = 1 << 24  # split the radiance pass into several when larger
# samples of a pixel are consecutive lanes: pre-reduce them within a SIMD packet, one atomic per packet
SCATTER_MODE = dr.ReduceMode.Local
# the features need UVs (textured albedo) and the shading frame, no surface derivatives
FEATURE_RAY_FLAGS = mi.RayFlags.Minimal | mi.RayFlags.UV | mi.RayFlags.ShadingFrame
#: the frozen kernels (dr.freeze) keep the recordings of the last 64 resolutions and spp of a scene (about 1 MB
#: each): at 8, a process that renders many settings (the evaluation: 29 spp values a scene) evicted and recorded
#: them again in nearly every frame, a trace each. A new one records, as expected: no warning about it
FREEZE_OPTIONS = {"limit": 64, "warn_after": 1 << 30}


#: A scene whose shapes moved this many times between the calls of one frozen kernel is an animation: the kernel runs
#: the plain function for it from then on. A recording made after a move serves the frame until the next move, so an
#: animation would record once a frame (slower than plain), and where several renderers share the scene (the sequence
#: benchmark's contenders) the later ones of a frame replayed what the first recorded: their frames were cheaper than
#: the same renderer's alone in an animation (docs/experiments.md).
ANIMATED_MOVES = 2
#: ... until it has been called this many times without a move: the animation stopped moving shapes (a light or the
#: camera may go on), and recordings pay again. A scene loaded once and used for an object's animation, then a
#: light's, ran its light frames plain (about 50 ms of a 256x256 frame; docs/experiments.md, sixty-fifth session);
#: the sequence benchmark's three renderers of one scene make 2 still calls between a frame's moves.
STILL_CALLS = 8


class FrozenKernel:
    """``function(scene, ...)`` recorded by ``dr.freeze`` once per scene and settings, then replayed.

    Each scene gets recordings of its own: replaying one scene's recording for another scene of the
    same layout read the first scene's freed objects (a batch that loads the scene again for every
    frame got garbage features now and then). The recordings live in the scene's
    :func:`~gmcpt.render.held.scene_state`, let go with it. Dr.Jit cannot record a virtual call when objects of another
    live scene share the call's registry (seen with the breakfast room loaded beside another scene): the recording
    raises, and that scene runs the plain function, with the same result. After a shape moved (through
    ``mi.traverse``) the kernel runs plain once, then records again; after :data:`ANIMATED_MOVES` moves it runs
    plain for that scene until :data:`STILL_CALLS` calls in a row saw no move. Call with a function that builds the
    arguments, so a failed recording leaves none dirty.
    """

    def __init__(self, function: Callable):
        self.function = function

    def __call__(self, scene: mi.Scene, arguments: Callable[[], tuple], integrator: object = None):
        state, shapes = scene_state(scene), geometry_key(scene)
        recordings, seen = state.setdefault("recordings", {}), state.setdefault("geometry", {})
        moves, still = state.setdefault("moves", {}), state.setdefault("still", {})
        moved, seen[self] = self in seen and seen[self] != shapes, shapes
        if moved:
            # shapes moved since this kernel last ran: a replay would trace the old geometry (or freed memory)
            for key in [key for key in recordings if key[0] is self]:
                del recordings[key]
            moves[self], still[self] = moves.get(self, 0) + 1, 0
        else:
            still[self] = still.get(self, 0) + 1
            if still[self] >= STILL_CALLS:
                moves[self] = 0
        if moved or moves.get(self, 0) >= ANIMATED_MOVES:
            return self._plain(scene, arguments)
        key = self.key(integrator)
        if key not in recordings:
            held = state.setdefault("recorded integrators", {})
            for old in making_room([other for other in held if other[0] is self]):
                del held[old]
                recordings.pop(old, None)
            recordings[key], held[key] = dr.freeze(self.function, **FREEZE_OPTIONS), integrator
        if recordings[key] is not None:
            try:
                return recordings[key](scene, *arguments())
            except RuntimeError:
                recordings[key] = None
        return self._plain(scene, arguments)

    def key(self, integrator: object = None) -> tuple:
        """The key of this kernel's recording for ``integrator`` among a scene's recordings: one for each integrator,
        since Dr.Jit replays a recording for any integrator of the same layout (two
        :class:`~gmcpt.render.guided_path.GuidedPath` with other light samples traced the first one's paths); the
        integrator is held while its recording is kept (:data:`~gmcpt.render.held.INTEGRATORS_KEPT`), so that no
        other takes its id."""
        return self, id(integrator)

    def _plain(self, scene: mi.Scene, arguments: Callable[[], tuple]):
        outputs = self.function(scene, *arguments())
        dr.eval(outputs)  # one kernel for all of them, as a replay gives (else one kernel a column read)
        return outputs


def geometry_key(scene: mi.Scene) -> tuple:
    """What changes when a mesh of ``scene`` moves through ``mi.traverse``: each mesh's vertex buffer (a new Dr.Jit
    variable on every update). A recording of :class:`FrozenKernel` replayed after such a move traced stale geometry
    (NaN pixels in the living room after four moves of a table; with every mesh buffer handed to the recording as an
    input, still wrong sums at some frames and right ones at others). A sphere, cylinder, disk or instance that moved
    (its ``to_world``, opaque or not) replays to the bit what the plain function traces (docs/experiments.md,
    sixty-fourth session), so it keeps its recordings: a light on a sphere that turns, as the breakfast room's sun."""
    return tuple(mesh.vertex_positions_buffer().index for mesh in _meshes(scene))


def _meshes(scene: mi.Scene) -> list:
    """The meshes of ``scene``, each once, those inside its shape groups too (an instance's shapes are not among
    ``scene.shapes()``, and a mesh moved inside a group replayed stale geometry), found once a scene."""
    state = scene_state(scene)
    if "meshes" not in state:
        meshes = [shape for shape in scene.shapes() if shape.is_mesh()]
        # mi.traverse also lists the top-level meshes whose vertices it exposes: the same objects
        meshes += [owner for key, (_, _, owner, _) in mi.traverse(scene).properties.items()
                   if key.endswith("vertex_positions") and not any(owner is mesh for mesh in meshes)]
        state["meshes"] = meshes
    return state["meshes"]


def pass_seed(seed: int, index: int, passes: int) -> int:
    """The sampler seed of radiance pass ``index`` of ``passes``: ``seed`` itself when there is one pass,
    else a 32-bit hash of (seed, index), which stays in range for every seed."""
    if passes == 1:
        return seed
    return int.from_bytes(hashlib.blake2b(f"{seed}/{index}".encode(), digest_size=4).digest(), "little")


def sensor_film_size(sensor: mi.Sensor) -> tuple[int, int]:
    """(height, width) of the sensor's film, its crop."""
    size = sensor.film().crop_size()
    return int(size[1]), int(size[0])


def primary_rays(sensor: mi.Sensor, sampler: mi.Sampler, pixel: mi.UInt32, width: int,
                  spp: int, jitter: mi.Point2f | None = None) -> tuple[mi.RayDifferential3f, mi.Color3f]:
    """Rays through ``pixel`` (flat index per lane), drawn as Mitsuba's integrators do; ``jitter``: where in the
    pixel, in [0, 1)^2 (default: the sampler's next draw, as Mitsuba's)."""
    film = sensor.film()
    pos = mi.Vector2u(pixel % width, pixel // width) + mi.Vector2u(film.crop_offset())
    pos_f = mi.Vector2f(pos) + (sampler.next_2d() if jitter is None else jitter)
    scale = dr.rcp(mi.ScalarVector2f(film.crop_size()))
    offset = -mi.ScalarVector2f(film.crop_offset()) * scale
    aperture = sampler.next_2d() if sensor.needs_aperture_sample() else mi.Point2f(0.5)
    ray_time = mi.Float(sensor.shutter_open())
    if sensor.shutter_open_time() > 0:
        ray_time += sampler.next_1d() * sensor.shutter_open_time()
    ray, weight = sensor.sample_ray_differential(time=ray_time, sample1=0.0,
                                                 sample2=dr.fma(pos_f, scale, offset), sample3=aperture)
    # opaque: a literal would make every spp a kernel of its own to compile (about 1 s on 2 cores)
    ray.scale_differential(dr.opaque(mi.Float, dr.rsqrt(float(spp))))
    return ray, weight


def seeded_sampler(sensor: mi.Sensor, spp: int, seed: int | mi.UInt32, lanes: int) -> mi.Sampler:
    """A clone of the sensor's sampler at ``spp`` samples a pixel, seeded with ``seed`` over ``lanes`` lanes."""
    sampler = sensor.sampler().clone()
    sampler.set_sample_count(spp)
    sampler.set_samples_per_wavefront(spp)
    sampler.seed(seed, lanes)
    return sampler


def _feature_means(scene: mi.Scene, sensor: mi.Sensor, seed: mi.UInt32, feature_spp: int, camera: tuple,
                   visibility: bool) -> list:
    """Per-pixel means of albedo (3), normal (3), hit distance, hit fraction, coverage and, with ``visibility``,
    light visibility over ``feature_spp`` primary rays (see :func:`render_features`); ``camera``
    (:func:`camera_key`) keys the recording of :data:`_frozen_feature_means`."""
    width, height = camera[0]
    lanes = height * width * feature_spp
    sampler = seeded_sampler(sensor, feature_spp, seed, lanes)
    # opaque, as in primary_rays: one compiled kernel for every feature_spp
    pixel = dr.arange(mi.UInt32, lanes) // dr.opaque(mi.UInt32, feature_spp)
    share = dr.opaque(mi.Float, 1 / feature_spp)  # a product, as Dr.Jit made of the division by a literal
    ray, _ = primary_rays(sensor, sampler, pixel, width, feature_spp)
    si = scene.ray_intersect(ray, FEATURE_RAY_FLAGS, True)
    hit = si.is_valid()
    values = first_hit_features(si, si.bsdf(ray))
    if visibility:
        _, emitter_weight = scene.sample_emitter_direction(si, sampler.next_2d(), True, hit)
        values.append(dr.select(hit & ((emitter_weight[0] + emitter_weight[1] + emitter_weight[2]) > 0), 1.0, 0.0))
    return pixel_means(values, pixel, share, height * width) if feature_spp > 1 else values


def pixel_means(values: list, pixel: mi.UInt32, share: mi.Float, pixels: int) -> list:
    """Each of ``values`` (one lane a ray) averaged over the rays of its ``pixel`` (``share``: 1 / rays a pixel),
    inside the kernel (as trace_pixels sums its radiance): one value per pixel comes back, not a buffer per ray."""
    means = [dr.zeros(mi.Float, pixels) for _ in values]
    for target, value in zip(means, values):
        dr.scatter_reduce(dr.ReduceOp.Add, target, value * share, pixel, mode=SCATTER_MODE)
    return means


#: :func:`_feature_means` recorded once per scene, resolution and feature spp, then replayed (as the radiance pass)
_frozen_feature_means = FrozenKernel(_feature_means)


@dataclass(frozen=True)
class FeatureMeans:
    """Per-pixel means of the feature rays, before they become buffers (:meth:`buffers`): flat float32 planes
    of albedo (3), normal (3), hit distance, hit fraction and coverage over ``spp`` rays, and visibility over
    ``visibility_spp`` rays (None where no shadow ray was traced). Two of them merge (:meth:`merged`)."""

    planes: tuple[np.ndarray, ...]
    spp: int
    visibility: np.ndarray | None
    visibility_spp: int
    shape: tuple[int, int]

    def merged(self, other: "FeatureMeans") -> "FeatureMeans":
        """The means over both sets of rays (weighted by their counts)."""
        spp = self.spp + other.spp
        planes = tuple((mine * self.spp + theirs * other.spp) / spp for mine, theirs in zip(self.planes, other.planes))
        sets = [(means.visibility, means.visibility_spp) for means in (self, other) if means.visibility is not None]
        visibility_spp = sum(count for _, count in sets)
        visibility = sum(plane * count for plane, count in sets) / visibility_spp if sets else None
        return FeatureMeans(planes, spp, visibility, visibility_spp, self.shape)

    def buffers(self) -> dict:
        """The buffers of :func:`render_features` (visibility 0 where no shadow ray was traced)."""
        height, width = self.shape
        columns = [plane.reshape(height, width) for plane in self.planes]
        albedo, normal = np.stack(columns[0:3], axis=-1), _unit_normals(columns[3:6], self.spp)
        distance, hit_fraction, coverage = columns[6:]
        distance = distance / np.maximum(hit_fraction, 1e-6)
        max_distance = float(distance.max()) if (hit_fraction > 0).any() else 1.0
        depth = np.where(hit_fraction > 0, distance / max(max_distance, 1e-12), 1.0)
        visible = (np.zeros(self.shape, np.float32) if self.visibility is None
                   else self.visibility.reshape(height, width))
        return {"albedo": albedo, "normal": normal, "depth": depth.astype(np.float32), "visibility": visible,
                "coverage": coverage}


def feature_means(scene: mi.Scene, sensor: mi.Sensor, feature_spp: int, seed: int = 0,
                  visibility: bool = True) -> FeatureMeans:
    """:class:`FeatureMeans` of ``feature_spp`` primary rays a pixel (seeded by ``seed``), with a shadow ray
    each where ``visibility``."""
    height, width = sensor_film_size(sensor)
    feature_seed = (seed + FEATURE_SEED_OFFSET) % SEED_LIMIT
    values = _frozen_feature_means(scene, lambda: (sensor, dr.opaque(mi.UInt32, feature_seed), feature_spp,
                                                   camera_key(sensor), visibility))
    columns = [np.asarray(value, dtype=np.float32) for value in values]
    return FeatureMeans(tuple(columns[:9]), feature_spp, columns[9] if visibility else None,
                        feature_spp if visibility else 0, (height, width))


def render_features(scene: mi.Scene, sensor: mi.Sensor, feature_spp: int = DEFAULT_FEATURE_SPP, seed: int = 0) -> dict:
    """Albedo, shading normal, depth and visibility for every pixel.

    Returns a dict of float32 arrays: ``albedo`` and ``normal`` (H, W, 3),
    ``depth``, ``visibility`` and ``coverage`` (H, W).

    ``albedo`` is the diffuse reflectance of BSDFs that have a diffuse lobe,
    clipped to [0, 1], and 0 for the others: Mitsuba's default
    ``eval_diffuse_reflectance`` (the BSDF times pi at normal incidence) gives
    a rough metal an "albedo" of 5 to 70 where its highlight faces the camera.
    ``coverage`` is the fraction of the pixel's rays whose albedo is at least
    :data:`~gmcpt.image.domain.ALBEDO_MIN` (the rays that demodulation divides).
    """
    return feature_means(scene, sensor, feature_spp, seed).buffers()


def _unit_normals(planes: list, feature_spp: int) -> np.ndarray:
    """(H, W, 3) normals from their three (H, W) float32 planes of per-pixel means: a mean of unit normals
    is renormalised (one sample is unit already, or 0 on a miss). Worked plane by plane: a norm over the
    short last axis of an (H, W, 3) array is ten times slower."""
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


def scalar_parameter(value) -> float:
    """A scene parameter as a Python float (``mi.traverse`` gives floats or one-lane Dr.Jit arrays)."""
    return float(value) if isinstance(value, (int, float)) else float(np.asarray(value).ravel()[0])


def camera_key(sensor: mi.Sensor) -> tuple:
    """The sensor's scalar settings that :func:`primary_rays` bakes into a kernel as constants."""
    film = sensor.film()
    return (tuple(film.crop_size()), tuple(film.crop_offset()), sensor.shutter_open(), sensor.shutter_open_time(),
            sensor.needs_aperture_sample())


def _pixel_sums(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, pixels: mi.UInt32,
                lane: mi.UInt32, seed: mi.UInt32, spp: int, camera: tuple, sums: list,
                quarters: list = (), by_film: bool = False) -> list | tuple[list, list]:
    """Path trace lane ``k * spp + s`` (``lane`` counts them) as sample ``s`` of pixel ``pixels[k]`` and add
    (R, G, B, squared norm, finite count) of the finite samples to ``sums`` (five zero arrays, one value a pixel),
    and where ``sums`` holds more arrays, the integrator's AOVs of every sample (the guides of
    :class:`~gmcpt.render.guided_path.GuidedPath`). With ``quarters`` (four zero arrays, four values a pixel of the
    film), also (R, G, B, finite count) by the film's pixel and the quarter of it each sample fell in
    (:func:`trace_pixel_quarters`), returned as ``(sums, quarters)``.

    With ``by_film``, ``sums`` hold one value a pixel of the film and each sample adds to its film pixel's: a pixel
    listed once a sample (:func:`trace_counts`) is summed in the kernel.

    Every size comes from an argument's width, so :data:`_frozen_pixel_sums` replays its kernel for any
    pixel count; ``camera`` (:func:`camera_key`) only keys the recording.
    """
    sampler = seeded_sampler(sensor, spp, seed, dr.width(lane))
    lane_pixel = lane // dr.opaque(mi.UInt32, spp)  # as in primary_rays: one compiled kernel for every spp
    jitter = sampler.next_2d()  # the draw primary_rays would make: the same samples, their place in the pixel known
    film_pixel = dr.gather(mi.UInt32, pixels, lane_pixel)
    ray, weight = primary_rays(sensor, sampler, film_pixel, camera[0][0], spp, jitter)
    radiance, _, aovs = integrator.sample(scene, sampler, ray, sensor.get_medium(), True)
    radiance = weight * radiance
    finite = dr.isfinite(radiance[0]) & dr.isfinite(radiance[1]) & dr.isfinite(radiance[2])
    radiance = dr.select(finite, radiance, 0.0)
    # Accumulate per pixel inside the path tracing kernel (as the film does,
    # with as many channels: RGB, squared norm, count of finite samples).
    values = [radiance[0], radiance[1], radiance[2], dr.squared_norm(radiance), dr.select(finite, 1.0, 0.0), *aovs]
    for target, value in zip(sums, values):
        dr.scatter_reduce(dr.ReduceOp.Add, target, value, film_pixel if by_film else lane_pixel, mode=SCATTER_MODE)
    if quarters:
        quarter = film_pixel * 4 + dr.select(jitter.x >= 0.5, 1, 0) + dr.select(jitter.y >= 0.5, 2, 0)
        for target, value in zip(quarters, values[:3] + values[4:5]):
            dr.scatter_reduce(dr.ReduceOp.Add, target, value, quarter, mode=SCATTER_MODE)
        return sums, quarters
    return sums


#: :func:`_pixel_sums` recorded once per scene, integrator, spp and camera, then replayed: tracing the path
#: integrator's kernel in Python costs about 10 ms a pass (a tenth of that replayed), as much as 2 % of a
#: cheap 16-spp frame. A recording costs about what one plain trace does.
_frozen_pixel_sums = FrozenKernel(_pixel_sums)
#: the same with a :class:`~gmcpt.render.guided_path.GuidedPath`'s AOVs: recorded apart, so that a scene where it cannot
#: be recorded still replays the plain kernel
_frozen_guided_sums = FrozenKernel(_pixel_sums)
#: the same with the sums by the pixel's quarters (:func:`trace_pixel_quarters`)
_frozen_quarter_sums = FrozenKernel(_pixel_sums)


def _film_pixel_sums(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, pixels: mi.UInt32,
                     lane: mi.UInt32, seed: mi.UInt32, spp: int, camera: tuple, sums: list) -> list:
    """:func:`_pixel_sums` by film pixel (``dr.freeze`` records plain functions only)."""
    return _pixel_sums(scene, sensor, integrator, pixels, lane, seed, spp, camera, sums, by_film=True)


#: the same by film pixel (:func:`trace_film_pixels`)
_frozen_film_sums = FrozenKernel(_film_pixel_sums)


def trace_pixels(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator,
                 pixels: np.ndarray, spp: int, seed: int | np.ndarray = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Path trace ``spp`` samples for each flat pixel index in ``pixels``; ``seed`` one for all lanes or, as an
    array, each lane's own (a lane draws from its seed and its index alone).

    Returns float32 ``(sum, sum_of_squares, count)`` over the finite samples,
    shapes (n, 3), (n,) and (n,); the sum of squares is summed over the three
    channels (all that the channel-averaged variance needs).
    """
    red, green, blue, squares, count = _traced_sums(scene, sensor, integrator, pixels, spp, seed)
    return np.stack([red, green, blue], axis=1), squares, count


def trace_pixel_quarters(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator,
                         pixels: np.ndarray, spp: int, seed: int | np.ndarray = 0) -> tuple[np.ndarray, ...]:
    """:func:`trace_pixels` (the same samples), and their sums by the film's pixel and the quarter of it each fell
    in: (N, 4, 4) float32 over the film's N pixels, for each quarter (left top, right top, left bottom, right bottom)
    R, G, B and the finite count. A sequence's history reads them where the camera moved
    (:mod:`gmcpt.temporal.reprojection`)."""
    red, green, blue, squares, count, *quarters = _traced_sums(scene, sensor, integrator, pixels, spp, seed,
                                                               quarters=True)
    return (np.stack([red, green, blue], axis=1), squares, count,
            np.stack([quarter.reshape(-1, 4) for quarter in quarters], axis=2))


def trace_film_pixels(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator,
                      pixels: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sample of each entry of ``pixels`` (flat pixels of the film, repeated as often as they are to be
    sampled, each pixel's entries together), summed by film pixel: :func:`trace_pixels`' (sum (N, 3), sum of
    squared norms (N,), finite count (N,)) over the film's N pixels: a pass of uneven samples a pixel returns the
    film's sums, not one row a sample to be binned afterwards (docs/experiments.md, sixty-first session)."""
    red, green, blue, squares, count = _traced_sums(scene, sensor, integrator, pixels, 1, seed, by_film=True)
    return np.stack([red, green, blue], axis=1), squares, count


def _traced_sums(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, pixels: np.ndarray, spp: int,
                 seed: int, aovs: int = 0, quarters: bool = False, by_film: bool = False) -> list[np.ndarray]:
    """:func:`_pixel_sums` through the frozen kernel, as float32 arrays: the five sums (``by_film``: by film pixel),
    then ``aovs`` AOV sums, or with ``quarters`` the four sums by the film's pixels' quarters (four values a pixel of
    the film)."""
    # opaque zeros and seed: literals that change between calls would make the frozen function record again
    kernel = (_frozen_quarter_sums if quarters else _frozen_guided_sums if aovs
              else _frozen_film_sums if by_film else _frozen_pixel_sums)
    zeros = lambda count, size: [dr.opaque(mi.Float, 0.0, size) for _ in range(count)]  # noqa: E731
    film_pixels = math.prod(sensor_film_size(sensor))
    outputs = kernel(scene, lambda: (sensor, integrator, aligned_uint32(pixels),
                                     dr.arange(mi.UInt32, pixels.size * spp), _lane_seeds(seed), spp,
                                     camera_key(sensor), zeros(5 + aovs, film_pixels if by_film else pixels.size),
                                     *([zeros(4, 4 * film_pixels)] if quarters else [])), integrator)
    columns = [*outputs[0], *outputs[1]] if quarters else outputs
    return [np.asarray(column) for column in columns]


def _lane_seeds(seed: int | np.ndarray) -> mi.UInt32:
    """The sampler seed of every lane: one, opaque (a literal that changes would record another kernel), or each
    lane's own."""
    if isinstance(seed, np.ndarray):
        return aligned_uint32(seed)
    return dr.opaque(mi.UInt32, seed)


#: Bytes the NumPy arrays handed to Dr.Jit are aligned to (:func:`aligned_array`)
ALIGNMENT = 64


def aligned_array(values: np.ndarray, dtype) -> np.ndarray:
    """``values`` flat as ``dtype``, copied to memory aligned to :data:`ALIGNMENT` bytes. Dr.Jit reads a NumPy array
    in place and takes its alignment into the kernel: an input whose alignment changes compiles another kernel, or
    records a frozen one again. NumPy's allocations fall at any 16 bytes: a warm sequence frame recorded its path
    kernel again about once in 15 frames, 25-40 ms each (docs/experiments.md, sixty-sixth session)."""
    values = np.asarray(values, dtype).ravel()
    words = ALIGNMENT // values.itemsize
    buffer = np.empty(values.size + words, dtype)
    start = (-buffer.ctypes.data % ALIGNMENT) // values.itemsize
    aligned = buffer[start:start + values.size]
    aligned[...] = values
    return aligned


def aligned_uint32(values: np.ndarray) -> mi.UInt32:
    """``values`` as a Dr.Jit UInt32 on aligned memory (:func:`aligned_array`)."""
    return mi.UInt32(aligned_array(values, np.uint32))


def trace_counts(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, counts: np.ndarray,
                 seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trace ``counts[p]`` samples of each flat pixel ``p``: (sum (N, 3), sum of squared norms (N,), finite sample
    count (N,)), float64.

    Each sample is one lane of a 1-spp pass over the pixel list with repeats, split into parts of at most
    :data:`MAX_LANES` lanes with a seed of its own per part.
    """
    return trace_counts_after(scene, sensor, integrator, counts, seed, [])[:3]


def trace_counts_after(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, counts: np.ndarray,
                       seed: int, ahead: list[tuple[np.ndarray, int]], quarters: bool = False) -> tuple:
    """:func:`trace_counts` with one sample of each pixel of the groups ``ahead`` ((flat pixels (K,), seed) each)
    traced first, each group in the next K lanes of the first part, its lanes drawing from its own seed: (sum, sum
    of squared norms, finite count (over the film, all samples), each group's own samples (K, 3) float32, NaN
    where not finite, and with ``quarters`` the sums by the pixel's quarters (N, 4, 4), as
    :func:`trace_pixel_quarters` gives them, else None). A group traced again at the same lanes with the same seed
    traces the same samples (a lane draws from its seed and its index alone): :mod:`gmcpt.temporal.gradient`'s
    replay, in the same launch."""
    first = [pixels.astype(np.int64) for pixels, _ in ahead]
    lanes = np.concatenate([*first, np.repeat(np.arange(counts.size), counts)])
    total, squares, finite = np.zeros((counts.size, 3)), np.zeros(counts.size), np.zeros(counts.size)
    by_quarter = np.zeros((counts.size, 4, 4), np.float32) if quarters else None
    ends = np.cumsum([0] + [pixels.size for pixels in first])
    chunks = _parts(lanes, int(ends[-1]))
    parts = len(chunks)
    own = []
    for index, chunk in enumerate(chunks):
        if chunk.size == 0:
            continue
        chunk_seed = pass_seed(seed, index, parts)
        if index == 0 and ahead:
            chunk_seed = np.full(chunk.size, chunk_seed, np.uint32)
            for (_, group_seed), start, end in zip(ahead, ends[:-1], ends[1:]):
                chunk_seed[start:end] = group_seed
        if quarters:
            sums, chunk_squares, count, chunk_quarters = trace_pixel_quarters(scene, sensor, integrator, chunk, 1,
                                                                              chunk_seed)
            by_quarter += chunk_quarters
        elif ahead:
            sums, chunk_squares, count = trace_pixels(scene, sensor, integrator, chunk, 1, chunk_seed)
        else:
            sums, chunk_squares, count = trace_film_pixels(scene, sensor, integrator, chunk, chunk_seed)
            total += sums
            squares += chunk_squares
            finite += count
            continue
        if index == 0:
            own = [np.where(count[start:end, None] > 0, sums[start:end], np.float32(np.nan)).astype(np.float32)
                   for start, end in zip(ends[:-1], ends[1:])]
        for channel in range(3):
            total[:, channel] += np.bincount(chunk, weights=sums[:, channel], minlength=counts.size)
        squares += np.bincount(chunk, weights=chunk_squares, minlength=counts.size)
        finite += np.bincount(chunk, weights=count, minlength=counts.size)
    return total, squares, finite, own, by_quarter


def _parts(lanes: np.ndarray, head: int) -> list[np.ndarray]:
    """``lanes`` split into as few parts of at most :data:`MAX_LANES` as there can be, evenly, except that the first
    holds at least the ``head`` lanes of the groups traced ahead (a group replays only in the lanes it had)."""
    if head > MAX_LANES:
        raise GmcptError(f"a film this large traces {head} probe lanes, more than one launch holds ({MAX_LANES}); "
                         "render the sequence at a smaller resolution")
    parts = max(1, -(-lanes.size // MAX_LANES))
    chunks = np.array_split(lanes, parts)
    if chunks[0].size >= head:
        return chunks
    return [lanes[:head], *np.array_split(lanes[head:], parts - 1)]


#: Up to this many samples (pixels x spp), Mitsuba's render of every pixel is traced by the frozen pixel-list
#: kernel (:func:`trace_pixels`), which draws the same samples: ``mi.render`` traces the integrator in Python on
#: every call, 4-20 ms at 256x256 (living room at 1 spp: 79 ms against 100), while above this its film gathers
#: the samples faster (256x256 at 16 spp: 1-2% faster; 1920x1080 at 1 spp: 4%; docs/experiments.md).
FROZEN_FRAME_SAMPLES = 1 << 19


def render_native(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, spp: int,
                  seed: int, any_size: bool = False) -> np.ndarray:
    """Mitsuba's render of every pixel at ``spp`` samples with the scene's integrator, (N, 3) float32 flat: each
    pixel the mean of its own samples, non-finite where one of them was (as ``mi.render``'s film gives it, so that
    :meth:`SampleSums.add_native` counts that pixel's samples as dropped). ``mi.render`` itself, or for a box
    filter and at most :data:`FROZEN_FRAME_SAMPLES` samples (``any_size``: any number) the same samples through the
    frozen kernel, whose one compiled kernel serves every spp where ``mi.render`` compiles one for each. The
    sensor's sampler keeps its own sample count (``mi.render`` sets it)."""
    return _render_full(scene, sensor, integrator, spp, seed, 0, any_size)[0]


def render_native_quarters(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, spp: int,
                           seed: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`render_native` of a box filter's film through the frozen kernel at any spp (the same samples), and its
    samples' sums by quarter of the pixel (N, 4, 4; :func:`trace_pixel_quarters`)."""
    height, width = sensor_film_size(sensor)
    total, _, count, quarters = trace_pixel_quarters(scene, sensor, integrator, np.arange(height * width), spp, seed)
    return _film_mean(total, count, spp), quarters


def _film_mean(total: np.ndarray, count: np.ndarray, spp: int) -> np.ndarray:
    """(N, 3) float32 the mean of each pixel's ``spp`` samples from the frozen kernel's sums ``total`` (N, 3, divided
    in place), non-finite where one of them was (the kernel leaves non-finite samples out; the film does not)."""
    if spp > 1:
        total /= np.float32(spp)
    total[count < spp] = np.nan
    return total


def render_native_guided(scene: mi.Scene, sensor: mi.Sensor, twin: mi.SamplingIntegrator, spp: int,
                         seed: int, any_size: bool = False) -> tuple[np.ndarray, FeatureMeans]:
    """:func:`render_native` with ``twin`` (:func:`gmcpt.render.guided_path.guided_twin` of the scene's integrator: the
    same image) and the :class:`FeatureMeans` of its first hits, guides of ``spp`` rays a pixel."""
    image, planes = _render_full(scene, sensor, twin, spp, seed, len(FEATURE_PLANES), any_size)
    return image, FeatureMeans(tuple(planes), spp, None, 0, sensor_film_size(sensor))


def warm_native(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, guided: bool) -> None:
    """Compile (or find compiled) the frozen kernel that :func:`render_native` (with ``guided``,
    :func:`render_native_guided`) runs at ``any_size``, by tracing one sample of a few pixels: the kernel serves
    every pixel count and spp, so that a whole frame's pass then takes its own time, not its compilation's. Nothing
    where the film's filter is wider than a pixel (``mi.render`` renders it)."""
    if not box_filter(sensor):
        return
    height, width = sensor_film_size(sensor)
    _traced_sums(scene, sensor, integrator, np.arange(min(64, height * width)), 1, 0,
                 len(FEATURE_PLANES) if guided else 0)


def box_filter(sensor: mi.Sensor) -> bool:
    """Whether each sample lands in its own pixel alone, as the frozen kernel's sums take it."""
    return sensor.film().rfilter().radius() <= 0.5


def _render_full(scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator, spp: int, seed: int,
                 aovs: int, any_size: bool) -> tuple[np.ndarray, list[np.ndarray]]:
    """(the image, (N, 3), and the per-pixel means of the integrator's first ``aovs`` AOVs, flat float32 planes)."""
    height, width = sensor_film_size(sensor)
    if (any_size or height * width * spp <= FROZEN_FRAME_SAMPLES) and box_filter(sensor):
        red, green, blue, _, count, *planes = _traced_sums(scene, sensor, integrator, np.arange(height * width), spp,
                                                           seed, aovs)
        if spp > 1:
            planes = [plane / np.float32(spp) for plane in planes]
        return _film_mean(np.stack([red, green, blue], axis=1), count, spp), planes
    sampler = sensor.sampler()
    count = sampler.sample_count()
    try:
        image = np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, spp=spp, seed=seed),
                           dtype=np.float32).reshape(height * width, -1)
        return image[:, :3], [np.ascontiguousarray(image[:, 3 + plane]) for plane in range(aovs)]
    finally:
        sampler.set_sample_count(count)


class SampleSums:
    """Per-pixel sums of path samples over all of a frame's passes (flat pixels): every strategy traces into one.

    ``samples`` counts the samples traced, finite or not; ``finite`` a pixel's finite ones. A native pass
    (:meth:`add_native`) brings no squares: its pixels' variance is that of the other passes' samples alone.
    While every sample so far is a native pass's, the sums are kept as a float32 mean and a pixel-list pass is
    folded into it, its squares dropped (a dense frame's top-up of one sample a pixel has no variance to give).
    """

    def __init__(self, pixels: int, quarters: bool = False):
        self.size = pixels
        self._total, self.squares, self.finite = np.zeros((pixels, 3)), np.zeros(pixels), np.zeros(pixels)
        #: with ``quarters``, the sums by the pixel's quarters (N, 4, 4; :func:`trace_pixel_quarters`), kept by
        #: :meth:`trace_counts` and :meth:`add_native` with :func:`render_native_quarters`' sums; None after any
        #: other pass
        self.quarters = np.zeros((pixels, 4, 4), np.float32) if quarters else None
        self.squared_samples = np.zeros(pixels)  # finite samples that brought their squares
        self.samples = 0
        # a frame of finite native passes and top-ups (a dense frame's usual case) keeps Mitsuba's float32 image
        # as its mean, and makes the float64 sums only if another kind of pass comes (2-3 ms a frame at 256x256,
        # 0.4 s at 1920x1080)
        self._native_mean: np.ndarray | None = None
        self._mean_is_own = False

    @property
    def total(self) -> np.ndarray:
        """(N, 3) float64 sums of the finite samples."""
        if self._native_mean is not None:
            self._total, self._native_mean = self._native_mean * self.finite[:, None], None
        return self._total

    @total.setter
    def total(self, value: np.ndarray) -> None:
        self._total, self._native_mean = value, None

    def trace(self, scene, sensor, integrator, pixels: np.ndarray, spp: int, seed: int,
              say: Callable[[str], None] = lambda message: None) -> np.ndarray | None:
        """``spp`` samples of each flat pixel in ``pixels`` (consecutive lanes), in launches of at most
        :data:`MAX_LANES` lanes, each seeded by :func:`pass_seed`. Returns their own mean, (n, 3) float32, NaN
        where none was finite (None for no pixels)."""
        if pixels.size == 0:
            return None
        self.quarters = None  # this pass keeps no sums by quarter
        passes = max(1, -(-pixels.size * spp // MAX_LANES))
        pass_spp, done = -(-spp // passes), 0
        own_total = own_count = None  # this call's own sums, over its passes
        for index in range(passes):
            this_spp = min(pass_spp, spp - done)
            if this_spp <= 0:
                break
            say(f"path tracing: {pixels.size} px x {spp} spp" + (f" (pass {index + 1}/{passes})" if passes > 1 else ""))
            total, squares, count = trace_pixels(scene, sensor, integrator, pixels, this_spp,
                                                 pass_seed(seed, index, passes))
            own_total, own_count = (total, count) if own_total is None else (own_total + total, own_count + count)
            if self._native_mean is not None:
                self._fold(pixels, total, count)
            else:
                self._add(pixels, total, squares, count)
            done += this_spp
        self.samples += pixels.size * spp
        with np.errstate(divide="ignore", invalid="ignore"):
            return own_total / own_count[:, None]

    def _add(self, pixels: np.ndarray, total: np.ndarray, squares: np.ndarray, count: np.ndarray) -> None:
        """Add a pixel-list pass's sums (``total`` (n, 3), ``squares`` and finite ``count`` (n,)) of the flat
        ``pixels`` (each once) to the float64 sums: written into zeros and added where the list is most of the frame,
        which costs half of adding at the list (1.3 ms a pass at 256x256)."""
        if 2 * pixels.size < self.size:
            self.total[pixels] += total
            self.squares[pixels] += squares
            self.finite[pixels] += count
            self.squared_samples[pixels] += count
            return
        for target, values in ((self.total, total), (self.squares, squares), (self.finite, count),
                               (self.squared_samples, count)):
            spread = np.zeros(target.shape)
            spread[pixels] = values
            target += spread

    def _fold(self, pixels: np.ndarray, total: np.ndarray, count: np.ndarray) -> None:
        """Fold the finite samples' sums ``total`` ((n, 3)) and counts of the flat ``pixels`` into the native mean."""
        if not self._mean_is_own:  # the caller's image (or Mitsuba's buffer) is not ours to change
            self._native_mean, self._mean_is_own = self._native_mean.copy(), True
        before = self.finite[pixels]
        after = before + count
        # in float32 and in place: a top-up of 80% of a 1920x1080 frame folds in 0.06 s instead of 0.1
        folded = np.take(self._native_mean, pixels, axis=0)
        folded *= before.astype(np.float32)[:, None]
        folded += total
        folded /= np.maximum(after, 1).astype(np.float32)[:, None]
        self._native_mean[pixels] = folded
        self.finite[pixels] = after

    def trace_counts(self, scene, sensor, integrator, counts: np.ndarray, seed: int,
                     ahead: list[tuple[np.ndarray, int]] = ()) -> list[np.ndarray]:
        """``counts[p]`` more samples of each flat pixel ``p`` (:func:`trace_counts`), and one of each pixel of the
        groups ``ahead`` ahead of them, whose samples it returns (:func:`trace_counts_after`)."""
        total, squares, finite, own, quarters = trace_counts_after(scene, sensor, integrator, counts, seed,
                                                                   list(ahead), self.quarters is not None)
        if quarters is not None:
            self.quarters += quarters
        self.total, self.squares = self.total + total, self.squares + squares
        self.finite, self.squared_samples = self.finite + finite, self.squared_samples + finite
        self.samples += int(counts.sum()) + sum(pixels.size for pixels, _ in ahead)
        return own

    def add_native(self, image: np.ndarray, spp: int, quarters: np.ndarray | None = None) -> None:
        """A :func:`render_native` image of ``spp`` samples a pixel (kept as it is); a non-finite pixel's samples
        count as dropped. With its sums by quarter (:func:`render_native_quarters`) they join the frame's; without,
        the frame keeps none after it."""
        if self.quarters is not None and quarters is not None:
            self.quarters += quarters
        else:
            self.quarters = None
        if np.isfinite(image).all():  # the usual case, without the masked copies (0.35 s at 1920x1080)
            if self.samples == 0:  # the first pass is the frame (a dense frame's one launch)
                self._native_mean, self._mean_is_own = image, False
            else:
                self.total += image * np.float64(spp)
            self.finite += spp
        else:
            finite = np.isfinite(image).all(axis=1)
            self.total[finite] += image[finite] * spp
            self.finite[finite] += spp
        self.samples += image.shape[0] * spp

    def mean(self, where: np.ndarray | slice = slice(None)) -> np.ndarray:
        """(n, 3) the mean of the finite samples of the flat pixels ``where`` (0 where none)."""
        if self._native_mean is not None:
            return self._native_mean[where]
        return self.total[where] * (1.0 / np.maximum(self.finite[where], 1))[:, None]

    def estimate(self, where: np.ndarray | slice = slice(None)) -> tuple[np.ndarray, np.ndarray]:
        """(mean (n, 3), variance of the mean (n,)) of the flat pixels ``where``; the variance comes from the samples
        that brought their squares, scaled to the pixel's whole count."""
        mean = self.mean(where)
        if self._native_mean is not None:  # one native pass: its image is the mean, and it brings no squares
            return mean, np.zeros(mean.shape[0])
        inverse_count = 1.0 / np.maximum(self.finite[where], 1)
        squared = self.squared_samples[where]
        if not squared.any():  # native passes alone bring no squares
            return mean, np.zeros(mean.shape[0])
        # channel-averaged unbiased, in float64 (sum of squares minus n mean^2 cancels)
        sample_variance = (self.squares[where] - squared * np.einsum("ij,ij->i", mean, mean, dtype=np.float64)) \
            / (3 * np.maximum(squared - 1, 1))
        return mean, np.maximum(sample_variance, 0.0) * inverse_count
