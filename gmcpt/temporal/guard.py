"""A guard band for a moving camera: the surfaces just outside the film, traced before they come into view.

A pan brings new columns into view every frame, and they have no history: on the breakfast room's pan at 128x128 the
columns a pan brought in within the history's length were 5-8% of the pixels and 20-26% of the error
(docs/experiments.md). Where the last frame's motion says which sides of the film reveal new surfaces
(:func:`revealed`), a frame surveys a wider film (:class:`GuardBand`: the same camera, a wider field of view, the
same pixel pitch) and traces the budget's samples on the band of it beyond the revealing sides: a few frames later
those surfaces enter the view with a history like any other pixel's. A still camera, or one moving straight ahead,
reveals nothing and traces no band; nor does a side whose surfaces are no noisier than the rest (:func:`worth_a_band`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from ..render.kernels import scalar_parameter, sensor_film_size

#: The band's width beyond each side of the film, a share of the film's size: room for the history's frames of a
#: motion up to 1 pixel a frame at 128 pixels (the benchmark's pan) and 2 at 256.
BAND_SHARE = 1 / 16
#: The least motion (pixels a frame at the film's border) that counts as revealing a side.
REVEAL_SHIFT = 0.05
#: A band is traced only where the strips along the revealed sides are this many times as noisy as the whole frame
#: (:func:`worth_a_band`): a band costs 8-10% of a frame at budget 1, and what comes into view pays it back only
#: where it is noisier than the rest (docs/experiments.md).
BAND_NOISE_RATIO = 1.1


@dataclass(frozen=True)
class Sides:
    """Pixels of band to trace beyond each side of the film (0: none)."""

    left: int = 0
    right: int = 0
    top: int = 0
    bottom: int = 0

    def __bool__(self) -> bool:
        return bool(self.left or self.right or self.top or self.bottom)


@dataclass
class GuardBand:
    """A sensor like the frame's whose film is ``margin`` (x, y) pixels wider on each side; its inner pixels are the
    frame's (the same rays up to rounding)."""

    sensor: mi.Sensor
    margin: tuple[int, int]
    shape: tuple[int, int]  # (height, width) of the frame's own film

    @property
    def wide_shape(self) -> tuple[int, int]:
        return self.shape[0] + 2 * self.margin[1], self.shape[1] + 2 * self.margin[0]

    def inner(self, flat: np.ndarray) -> np.ndarray:
        """The frame's own pixels of a flat array over the wide film (N', ...), flat (N, ...)."""
        (height, width), (mx, my) = self.shape, self.margin
        wide = flat.reshape(*self.wide_shape, *flat.shape[1:])
        return np.ascontiguousarray(wide[my:my + height, mx:mx + width]).reshape(height * width, *flat.shape[1:])

    def embed(self, inner: np.ndarray, band: np.ndarray) -> np.ndarray:
        """``band`` (N', ...) over the wide film with the frame's own pixels replaced by ``inner`` (N, ...)."""
        (height, width), (mx, my) = self.shape, self.margin
        wide = band.reshape(*self.wide_shape, *band.shape[1:]).copy()
        wide[my:my + height, mx:mx + width] = inner.reshape(height, width, *inner.shape[1:])
        return wide.reshape(band.shape)

    def band_counts(self, sides: Sides, budget: float, seed: int) -> np.ndarray:
        """Samples a pixel (flat int over the wide film): ``budget`` on average on the band beyond each side in
        ``sides`` (as deep as it says), none elsewhere."""
        (height, width), (mx, my) = self.shape, self.margin
        chosen = np.zeros(self.wide_shape, bool)
        chosen[:, mx - min(sides.left, mx):mx] = True
        chosen[:, mx + width:mx + width + min(sides.right, mx)] = True
        chosen[my - min(sides.top, my):my, :] = True
        chosen[my + height:my + height + min(sides.bottom, my), :] = True
        pixels = np.flatnonzero(chosen)
        counts = np.zeros(chosen.size, np.int64)
        counts[pixels] = math.floor(budget)
        extra = int(round((budget - math.floor(budget)) * pixels.size))
        if extra:
            counts[np.random.default_rng(seed).choice(pixels, extra, replace=False)] += 1
        return counts


def centred_perspective(parameters) -> bool:
    """Whether ``parameters`` (``mi.traverse`` of a sensor) are a perspective camera's with its principal point at the
    film's centre and no crop window: a camera this module and :func:`gmcpt.temporal.sequence.camera_projection` know
    in closed form."""
    if "x_fov" not in parameters or "to_world" not in parameters:
        return False
    cropped = "film.crop_offset" in parameters and (any(parameters["film.crop_offset"]) or tuple(
        parameters["film.crop_size"]) != tuple(parameters["film.size"]))
    return not cropped and all(scalar_parameter(parameters[key]) == 0
                               for key in ("principal_point_offset_x", "principal_point_offset_y") if key in parameters)


def band_margin(shape: tuple[int, int], sides: Sides) -> tuple[int, int]:
    """The wide film's margin (x, y) for ``sides``: :data:`BAND_SHARE` of the film where a side of that axis reveals."""
    height, width = shape
    return (max(1, math.ceil(BAND_SHARE * width)) if sides.left or sides.right else 0,
            max(1, math.ceil(BAND_SHARE * height)) if sides.top or sides.bottom else 0)


def guard_band(sensor: mi.Sensor, sides: Sides, cache: dict) -> GuardBand | None:
    """The :class:`GuardBand` of ``sensor`` for ``sides`` (made once per field of view, clipping, film and margin in
    ``cache``, its camera moved to the sensor's each frame), or None: nothing revealed, or a sensor other than a
    centred perspective one."""
    if not sides:
        return None
    parameters = mi.traverse(sensor)
    if not centred_perspective(parameters):
        return None
    shape = sensor_film_size(sensor)
    margin = band_margin(shape, sides)
    x_fov, near, far = (scalar_parameter(parameters[key]) for key in ("x_fov", "near_clip", "far_clip"))
    # by what the band's sensor is made of, not by the sensor object: a scene loaded anew each frame has a new one
    key = (x_fov, near, far, shape, margin)
    if key not in cache:
        height, width = shape
        wide_width = width + 2 * margin[0]
        fov = math.degrees(2 * math.atan(math.tan(math.radians(x_fov) / 2) * wide_width / width))
        wide = mi.load_dict({"type": "perspective", "fov": fov, "fov_axis": "x", "near_clip": near, "far_clip": far,
                             "film": {"type": "hdrfilm", "width": wide_width, "height": height + 2 * margin[1],
                                      "rfilter": {"type": "box"}}})
        cache[key] = GuardBand(wide, margin, shape)
    band = cache[key]
    wide_parameters = mi.traverse(band.sensor)
    to_world = type(parameters["to_world"])(parameters["to_world"])
    dr.make_opaque(to_world)
    wide_parameters["to_world"] = to_world
    wide_parameters.update()
    return band


def revealed(film: np.ndarray, seen: np.ndarray, shape: tuple[int, int], history: int) -> Sides:
    """The sides of a ``shape`` (H, W) film that the camera's motion reveals, and how deep a band to trace there: the
    motion read from where each pixel's surface was on the last frame (``film`` (N, 2) in that frame's own film
    coordinates, valid where ``seen``), in the strips along each side (an eighth of the film); as deep as ``history``
    frames of that motion."""
    height, width = shape
    film, seen = film.reshape(height, width, 2), seen.reshape(height, width)
    near_x, near_y = max(2, width // 8), max(2, height // 8)

    def depth(strip: tuple, axis: int, sign: float) -> int:
        centres = (np.arange(width, dtype=np.float32)[strip[1]] if axis == 0
                   else np.arange(height, dtype=np.float32)[strip[0]][:, None]) + np.float32(0.5)
        moved = (film[strip][..., axis] - centres)[seen[strip]]
        if moved.size == 0:
            return 0
        pace = sign * float(np.median(moved))  # a surface at this side was further inside: the side reveals
        return math.ceil(pace * history) if pace > REVEAL_SHIFT else 0

    every = slice(None)
    return Sides(left=depth((every, slice(0, near_x)), 0, -1.0),
                 right=depth((every, slice(width - near_x, width)), 0, 1.0),
                 top=depth((slice(0, near_y), every), 1, -1.0),
                 bottom=depth((slice(height - near_y, height), every), 1, 1.0))


def worth_a_band(sides: Sides, own: np.ndarray, denoised: np.ndarray, shape: tuple[int, int]) -> Sides:
    """``sides``, or none where a band would not pay: the noise of the frame's own samples ``own`` (N, 3, linear)
    along the revealed sides (strips as wide as the band) against the whole frame's, read as their squared distance
    from the ``denoised`` frame (H, W, 3) in displayed values, at least :data:`BAND_NOISE_RATIO` times it."""
    if not sides:
        return sides
    height, width = shape
    own, denoised = own.reshape(height, width, 3), denoised.reshape(height, width, 3)

    def noise(where: tuple) -> float:
        shown = [np.clip(image[where], 0.0, 1.0) ** (1 / 2.2) for image in (own, denoised)]
        return float(((shown[0] - shown[1]) ** 2).mean())

    margin_x, margin_y = band_margin(shape, sides)
    every = slice(None)
    strips = [strip for strip, side in (((every, slice(0, margin_x)), sides.left),
                                        ((every, slice(width - margin_x, width)), sides.right),
                                        ((slice(0, margin_y), every), sides.top),
                                        ((slice(height - margin_y, height), every), sides.bottom)) if side]
    along = np.mean([noise(strip) for strip in strips])
    # the frame's own noise from every other pixel of every other row: a quarter of the work, the same mean
    return sides if along >= BAND_NOISE_RATIO * max(noise((slice(None, None, 2), slice(None, None, 2))), 1e-12) \
        else Sides()
