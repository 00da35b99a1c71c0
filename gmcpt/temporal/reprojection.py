"""The past frames' samples gathered into the current frame, in Dr.Jit: :func:`gmcpt.temporal.history.matches` and
:func:`gmcpt.temporal.history.unchanged` for every pixel, one kernel a past frame.

The same tests as the numpy functions (which stay the reference: the stability figures and the tests read them),
fused: on 2 cores the numpy reprojection of 8 past frames took 0.15-0.2 s of a 256x256 frame, the largest fixed
cost of a sequence frame (docs/experiments.md). A past frame's arrays move to Dr.Jit once (:func:`jit_frame`), and
its camera, weight and the frame's floor are opaque, so one kernel serves every frame of a sequence.
"""
from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from .history import ALBEDO_MARGIN, DEPTH_TOLERANCE, LIGHTING_RATIO, NORMAL_COSINE, PastFrame, Signature


@dataclass(frozen=True)
class JitFrame:
    """A :class:`~gmcpt.temporal.history.PastFrame`'s arrays as Dr.Jit arrays (:func:`jit_frame`)."""

    positions: mi.Point3f
    normals: mi.Vector3f
    marks: tuple  # lighting, albedo, lighting spread, albedo spread (mi.Float each)
    samples: tuple  # R, G, B sums and the count (mi.Float each)
    matrix: list  # the projection's 12 entries, opaque
    centre: mi.Point3f  # the camera's pinhole, opaque
    width: int
    height: int


@dataclass(frozen=True)
class Gathered:
    """What :func:`gather_history` returns, flat numpy over the current frame's pixels."""

    summed: np.ndarray  # (N, 4) weighted R, G, B sums and counts of the samples kept
    offered: np.ndarray  # (N,) bool: some past frame saw the pixel's surface
    lighting_dropped: np.ndarray  # (N,) bool: a past frame's samples left out for changed lighting
    material_dropped: np.ndarray  # (N,) bool: ... for a changed albedo (the lighting held)
    latest_seen: np.ndarray  # (N,) bool: the ``latest`` past frame's samples kept
    latest_film: np.ndarray  # (N, 2) where on that frame's film


def _float(values: np.ndarray) -> mi.Float:
    return mi.Float(np.ascontiguousarray(values, np.float32))


def _vector(values: np.ndarray, kind):
    return kind(*(_float(values[:, axis]) for axis in range(3)))


def _marks(marks: Signature) -> tuple:
    return tuple(_float(values) for values in (marks.lighting, marks.albedo, marks.lighting_spread,
                                                marks.albedo_spread))


def jit_frame(past: PastFrame) -> JitFrame:
    """``past``'s arrays in Dr.Jit (made once a frame, though it serves the frames after it)."""
    projection = past.projection
    matrix = [dr.opaque(mi.Float, float(value)) for value in projection.matrix.ravel()]
    centre = mi.Point3f(*(dr.opaque(mi.Float, float(value)) for value in projection.centre))
    samples = tuple(_float(column) for column in (*past.total.T, past.count))
    return JitFrame(_vector(past.positions, mi.Point3f), _vector(past.normals, mi.Vector3f), _marks(past.signature),
                    samples, matrix, centre, projection.width, projection.height)


def gather_history(frames: list[tuple[JitFrame, float, bool]], positions: np.ndarray, normals: np.ndarray,
                   marks: Signature, lighting_floor: float) -> Gathered:
    """The past ``frames`` ((frame, weight, whether it is the frame shown last) each) gathered into a frame whose
    pixels' centre rays hit ``positions`` (N, 3; NaN on a miss) with ``normals`` and whose signature is ``marks``:
    where a past pixel saw the same surface (:func:`gmcpt.temporal.history.matches`) under the same light and material
    (:func:`gmcpt.temporal.history.unchanged`), its samples count ``weight``."""
    pixels = positions.shape[0]
    point, normal, current = _vector(positions, mi.Point3f), _vector(normals, mi.Vector3f), _marks(marks)
    floor = dr.opaque(mi.Float, float(lighting_floor))
    summed = [dr.zeros(mi.Float, pixels) for _ in range(4)]
    offered, lighting_dropped, material_dropped = (dr.zeros(mi.Bool, pixels) for _ in range(3))
    latest_seen, latest_film = np.zeros(pixels, bool), np.zeros((pixels, 2), np.float32)
    for frame, weight, latest in frames:
        same, lit, same_material, u, v, source = _match(frame, point, normal, current, floor)
        held = same & lit & same_material
        scale = dr.opaque(mi.Float, float(weight))
        summed = [total + dr.select(held, dr.gather(mi.Float, values, source, held) * scale, 0.0)
                  for total, values in zip(summed, frame.samples)]
        offered |= same
        lighting_dropped |= same & ~lit
        material_dropped |= same & lit & ~same_material
        outputs = [*summed, offered, lighting_dropped, material_dropped] + ([held, u, v] if latest else [])
        dr.eval(*outputs)  # one kernel a past frame, all its outputs together
        if latest:
            latest_seen = np.asarray(held, bool)
            latest_film = np.stack([np.asarray(u, np.float32), np.asarray(v, np.float32)], axis=1)
    return Gathered(np.stack([np.asarray(total, np.float32) for total in summed], axis=1), np.asarray(offered, bool),
                    np.asarray(lighting_dropped, bool), np.asarray(material_dropped, bool), latest_seen,
                    np.where(latest_seen[:, None], latest_film, np.float32(0)))


def _match(frame: JitFrame, point: mi.Point3f, normal: mi.Vector3f, current: tuple, floor: mi.Float) -> tuple:
    """(same surface, lighting held, albedo held, past film x, y, past pixel) of every current pixel."""
    m = frame.matrix
    x = m[0] * point.x + m[1] * point.y + m[2] * point.z + m[3]
    y = m[4] * point.x + m[5] * point.y + m[6] * point.z + m[7]
    depth = m[8] * point.x + m[9] * point.y + m[10] * point.z + m[11]
    front = depth > 1e-9
    safe = dr.select(front, depth, 1.0)
    u, v = x / safe, y / safe
    column, row = dr.floor(u), dr.floor(v)
    inside = front & (column >= 0) & (column < frame.width) & (row >= 0) & (row < frame.height)
    source = dr.select(inside, mi.UInt32(row) * frame.width + mi.UInt32(column), 0)
    past_point = dr.gather(mi.Point3f, frame.positions, source, inside)
    past_normal = dr.gather(mi.Vector3f, frame.normals, source, inside)
    step, away = past_point - point, point - frame.centre
    same = inside & (dr.squared_norm(step) <= DEPTH_TOLERANCE ** 2 * dr.squared_norm(away)) & \
        (dr.dot(past_normal, normal) >= NORMAL_COSINE)
    shifted = dr.minimum(2 * dr.maximum(dr.abs(u - column - 0.5), dr.abs(v - row - 0.5)), 1.0)
    held = []
    for mine, theirs, my_spread, their_spread, ratio, margin in (
            (current[0], frame.marks[0], current[2], frame.marks[2], LIGHTING_RATIO, floor),
            (current[1], frame.marks[1], current[3], frame.marks[3], 0.0, ALBEDO_MARGIN)):
        theirs = dr.gather(mi.Float, theirs, source, same)
        spread = dr.maximum(my_spread, dr.gather(mi.Float, their_spread, source, same))
        held.append(dr.abs(mine - theirs) <= shifted * spread + ratio * dr.maximum(mine, theirs) + margin)
    return same, held[0], held[1], u, v, source
