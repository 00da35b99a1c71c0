"""A sequence frame's survey: one pass over its pixels before any path is traced, giving OIDN's guides, each pixel's
lighting signature and where its centre ray hit (:func:`survey`); the camera's projection (:func:`camera_projection`)
and the centre rays alone (:func:`geometry`)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from ..limits import SEED_LIMIT
from ..render.guided_path import first_hit_features
from ..render.kernels import (FEATURE_RAY_FLAGS, FeatureMeans, FrozenKernel, camera_key, pixel_means, primary_rays,
                              scalar_parameter, seeded_sampler, sensor_film_size)
from ..seeds import FEATURE_SEED_OFFSET
from .history import Projection, fit_projection


@dataclass(frozen=True)
class Survey:
    """A frame's pass over its pixels before any path is traced (:func:`survey`): where each pixel's centre ray
    hit (N, 3; NaN on a miss) and the shading normal there (N, 3), the guides' feature means over the pixel's
    guide rays (:class:`~gmcpt.render.kernels.FeatureMeans`), each pixel's lighting signature (N,: the luminance of the
    direct light through fixed light samples with the surface's BSDF toward the camera, plus what the surface
    emits, averaged over the guide rays), the camera's :class:`~gmcpt.temporal.history.Projection`, and the shape each
    centre ray hit (N,: its Dr.Jit registry index, 0 on a miss; :func:`~gmcpt.temporal.motion.shape_keys`)."""

    positions: np.ndarray
    normals: np.ndarray
    features: FeatureMeans
    lighting: np.ndarray
    projection: Projection
    shapes: np.ndarray


def _survey_planes(scene: mi.Scene, sensor: mi.Sensor, seed: mi.UInt32, guide_rays: int, camera: tuple) -> list:
    """The flat planes of :class:`Survey`: the feature planes and the lighting signature averaged over
    ``guide_rays`` rays a pixel, the first through its centre and the others jittered, then that centre ray's hit
    (x, y, z, normal x, y, z, hit, the shape's registry index): one launch (a second one for the centre rays cost
    about 5 ms of a 128x128 frame).

    The signature's light samples are four fixed points of the lights' sampling domain, one a guide ray in turn, a
    rook pattern (each a quarter of either coordinate: the first also picks the light, and a 2x2 grid gave each of
    two lights two points of one line): the same every frame, so a static surface under static lights keeps its
    signature, and a changed one is light that changed (a shadow that moved, a light switched or moved, a highlight
    that slid). Averaged over the pixel's rays, not read at its centre: an emitter's or a shadow's edge covering part
    of a pixel moves away unseen by a centre ray."""
    width, height = camera[0]
    lanes = height * width * guide_rays
    sampler = seeded_sampler(sensor, guide_rays, seed, lanes)
    lane = dr.arange(mi.UInt32, lanes)
    pixel = lane // dr.opaque(mi.UInt32, guide_rays)
    ray, _ = primary_rays(sensor, sampler, pixel, width, guide_rays)
    ray_index = lane - pixel * dr.opaque(mi.UInt32, guide_rays)
    # each pixel's first guide ray goes through its centre: the reprojection's ray, in the same launch
    first = ray_index == 0
    centre = _centre_ray(sensor, pixel, (width, height))
    ray.o, ray.d = dr.select(first, centre.o, ray.o), dr.select(first, centre.d, ray.d)
    # as the feature pass traces its camera rays (its flags, coherent): a fifth less than ray_intersect(ray) in the
    # breakfast room, the same sequence images (docs/experiments.md, sixty-sixth session)
    si = scene.ray_intersect(ray, FEATURE_RAY_FLAGS, True)
    hit = si.is_valid()
    bsdf = si.bsdf(ray)
    values = first_hit_features(si, bsdf)
    towards, weight = scene.sample_emitter_direction(si, signature_light_sample(ray_index), True, hit)
    light = bsdf.eval(mi.BSDFContext(), si, si.to_local(towards.d), hit & (towards.pdf > 0)) * weight
    light += dr.select(hit, si.emitter(scene).eval(si, hit), 0.0)
    values.append(dr.select(hit, (light.x + light.y + light.z) / 3, 0.0))
    means = pixel_means(values, pixel, dr.opaque(mi.Float, 1 / guide_rays), height * width)
    centres = [dr.zeros(mi.Float, height * width) for _ in range(8)]
    shape = mi.Float(dr.reinterpret_array(mi.UInt32, si.shape))  # exact: registry indices are far below 2^24
    for target, value in zip(centres, [*_hit_planes(si), shape]):
        dr.scatter(target, value, pixel, first)
    return means + centres


def signature_light_sample(ray: mi.UInt32) -> mi.Point2f:
    """The fixed light sample of a pixel's guide ray ``ray`` (0, 1, ...) for its lighting signature: four points in
    turn, a rook pattern over the lights' sampling domain (each point in its own quarter of either coordinate)."""
    corner = ray & 3
    return mi.Point2f((mi.Float(corner) + 0.5) * 0.25, (mi.Float((3 * corner + 1) & 3) + 0.5) * 0.25)


def _centre_planes(scene: mi.Scene, sensor: mi.Sensor, size: tuple[int, int]) -> list:
    """Where one ray through each pixel's centre of a ``size`` (W, H) film hits: x, y, z, normal x, y, z, hit."""
    width, height = size
    return _hit_planes(scene.ray_intersect(_centre_ray(sensor, dr.arange(mi.UInt32, height * width), size)))


def _centre_ray(sensor: mi.Sensor, pixel: mi.UInt32, size: tuple[int, int]) -> mi.Ray3f:
    """The ray through the centre of each lane's ``pixel`` (flat index) of a ``size`` (W, H) film."""
    width, height = size
    film = mi.Point2f(mi.Float(pixel % width) + 0.5, mi.Float(pixel // width) + 0.5)
    ray, _ = sensor.sample_ray(time=sensor.shutter_open(), sample1=0.0,
                               sample2=film / mi.ScalarVector2f(width, height), sample3=mi.Point2f(0.5))
    return ray


def _hit_planes(si: mi.SurfaceInteraction3f) -> tuple:
    """Where a ray hit: x, y, z, shading normal x, y, z, and 1 on a hit (0 on a miss)."""
    return (si.p.x, si.p.y, si.p.z, si.sh_frame.n.x, si.sh_frame.n.y, si.sh_frame.n.z,
            dr.select(si.is_valid(), 1.0, 0.0))


#: :func:`_survey_planes` recorded once per scene, film and guide rays, then replayed; :func:`_centre_planes` alone
#: for :func:`geometry`
_frozen_survey = FrozenKernel(_survey_planes)
_frozen_centres = FrozenKernel(_centre_planes)


def survey(scene: mi.Scene, sensor: mi.Sensor, guide_rays: int = 4, seed: int = 0) -> Survey:
    """This frame's :class:`Survey` over ``guide_rays`` rays a pixel (seeded by ``seed``), in one pass."""
    height, width = sensor_film_size(sensor)
    feature_seed = (seed + FEATURE_SEED_OFFSET) % SEED_LIMIT
    planes = [np.asarray(plane, np.float32) for plane in
              _frozen_survey(scene, lambda: (sensor, dr.opaque(mi.UInt32, feature_seed), guide_rays,
                                             camera_key(sensor)))]
    features, lighting = planes[:9], planes[9]
    positions, normals = _hits(planes[10:17])
    return Survey(positions, normals, FeatureMeans(tuple(features), guide_rays, None, 0, (height, width)), lighting,
                  camera_projection(sensor), planes[17].astype(np.int64))


def _hits(planes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """(positions, normals) (N, 3) each, NaN on a miss, of :func:`_centre_planes`' planes. float32, as traced: the
    reprojection of 8 past frames reads them every frame, at half float64's traffic."""
    hit = planes[6][:, None] > 0
    return (np.where(hit, np.stack(planes[0:3], axis=1), np.float32(np.nan)),
            np.where(hit, np.stack(planes[3:6], axis=1), np.float32(np.nan)))


def centred_perspective(parameters) -> bool:
    """Whether ``parameters`` (``mi.traverse`` of a sensor) are a perspective camera's with its principal point at the
    film's centre and no crop window: a camera :func:`camera_projection` knows in closed form."""
    if "x_fov" not in parameters or "to_world" not in parameters:
        return False
    cropped = "film.crop_offset" in parameters and (any(parameters["film.crop_offset"]) or tuple(
        parameters["film.crop_size"]) != tuple(parameters["film.size"]))
    return not cropped and all(scalar_parameter(parameters[key]) == 0
                               for key in ("principal_point_offset_x", "principal_point_offset_y") if key in parameters)


def camera_projection(sensor: mi.Sensor) -> Projection:
    """The sensor's :class:`~gmcpt.temporal.history.Projection`: a centred perspective camera's from its field of view
    and its camera (the same as the fit to 1e-5; the fit cost 2-5 ms a frame), any other's fitted from rays through
    an 8x8 grid of pixel centres (a grid, not a line of them: 11 numbers to fit)."""
    height, width = sensor_film_size(sensor)
    parameters = mi.traverse(sensor)
    if centred_perspective(parameters):
        # Mitsuba's camera looks along +z, its +x and +y towards the film's left and top
        focal = width / (2 * math.tan(math.radians(scalar_parameter(parameters["x_fov"])) / 2))
        intrinsic = np.array([[-focal, 0, width / 2], [0, -focal, height / 2], [0, 0, 1]])
        to_camera = np.array(sensor.world_transform().inverse().matrix, np.float64).reshape(4, 4)
        return Projection(intrinsic @ to_camera[:3], width, height)
    return fitted_projection(sensor)


def fitted_projection(sensor: mi.Sensor) -> Projection:
    """The sensor's :class:`~gmcpt.temporal.history.Projection` fitted from its rays (any pinhole camera)."""
    height, width = sensor_film_size(sensor)
    columns, rows = np.meshgrid(np.linspace(0, width - 1, 8).round() + 0.5, np.linspace(0, height - 1, 8).round() + 0.5)
    film = np.stack([columns.ravel(), rows.ravel()], axis=1)
    ray, _ = sensor.sample_ray(time=sensor.shutter_open(), sample1=0.0,
                               sample2=mi.Point2f(*(film / [width, height]).T.astype(np.float32)),
                               sample3=mi.Point2f(0.5))
    lanes = film.shape[0]  # a camera whose rays share an origin or a direction gives one lane of it
    origins = np.broadcast_to(_columns(ray.o), (lanes, 3))
    return fit_projection(film, origins, np.broadcast_to(_columns(ray.d), (lanes, 3)), width, height)


def geometry(scene: mi.Scene, sensor: mi.Sensor) -> tuple[np.ndarray, np.ndarray, Projection]:
    """Where each pixel's centre ray hits (N, 3; NaN on a miss), the shading normal there (N, 3), and the
    camera's :class:`~gmcpt.temporal.history.Projection`: the centre rays of :func:`survey` alone (no guides, no shadow
    rays), for the stability figures and the benchmark's accumulation baseline."""
    height, width = sensor_film_size(sensor)
    planes = [np.asarray(plane, np.float32) for plane in _frozen_centres(scene, lambda: (sensor, (width, height)))]
    return (*_hits(planes), camera_projection(sensor))


def _columns(vector, dtype=np.float64) -> np.ndarray:
    """A Dr.Jit 3-vector of N lanes as (N, 3) ``dtype``."""
    return np.stack([np.asarray(vector.x), np.asarray(vector.y), np.asarray(vector.z)], axis=1).astype(dtype,
                                                                                                     copy=False)
