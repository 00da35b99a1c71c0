"""The past frames' samples gathered into the current frame, in Dr.Jit: :func:`gmcpt.temporal.history.matches` and
:func:`gmcpt.temporal.history.unchanged` for every pixel, one kernel a past frame.

The same tests as the numpy functions (which stay the reference: the stability figures and the tests read them),
fused, plus one the numpy functions do not make: where the past pixel a point lands in saw another surface and the
camera moved (an edge), another of the four past pixels around the point may serve (:func:`_match`). On 2 cores the
numpy reprojection of 8 past frames took 0.15-0.2 s of a 256x256 frame, the largest fixed cost of a sequence frame
(docs/experiments.md). A past frame's arrays move to Dr.Jit once (:func:`jit_frame`), and
its camera, weight and the frame's floor are opaque, so one kernel serves every frame of a sequence. The frame
shown before is read along the motion here too (:func:`cubic_sample`, the carry's Catmull-Rom read).
"""
from __future__ import annotations

from dataclasses import dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from ..render.kernels import aligned_array
from .history import (ALBEDO_MARGIN, DEPTH_TOLERANCE, LIGHTING_RATIO, NORMAL_COSINE, SHIFT_SEEN, PastFrame,
                      Signature)


@dataclass(frozen=True)
class JitFrame:
    """A :class:`~gmcpt.temporal.history.PastFrame`'s arrays as Dr.Jit arrays (:func:`jit_frame`)."""

    positions: mi.Point3f
    normals: mi.Vector3f
    marks: tuple  # lighting, albedo, lighting spread, albedo spread (mi.Float each)
    samples: tuple  # R, G, B sums and the count (mi.Float each)
    quarters: tuple | None  # the same by the pixel's quarters (four values a pixel: pixel * 4 + quarter), or None
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
    latest_film: np.ndarray  # (N, 2) float32 where on that frame's film, 0 where not seen


def _float(values: np.ndarray) -> mi.Float:
    """``values`` as a Dr.Jit array on aligned memory (:func:`~gmcpt.render.kernels.aligned_array`: arrays that
    landed on other alignments each compiled another kernel, 70-90 ms)."""
    return mi.Float(aligned_array(values, np.float32))


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
    quarters = None if past.quarters is None else tuple(_float(past.quarters[:, :, value]) for value in range(4))
    return JitFrame(_vector(past.positions, mi.Point3f), _vector(past.normals, mi.Vector3f), _marks(past.signature),
                    samples, quarters, matrix, centre, projection.width, projection.height)


def gather_history(frames: list[tuple], positions: np.ndarray, normals: np.ndarray, marks: Signature,
                   lighting_floor: float) -> Gathered:
    """The past ``frames`` ((frame, weight, whether it is the frame shown last, whether the camera moved since, and
    where the surface points were then where a shape moved (positions, and normals or None where none turned;
    :func:`gmcpt.temporal.motion.points_then`) or None) each) gathered into a frame whose pixels' centre rays hit
    ``positions`` (N, 3; NaN on a miss) with ``normals`` and whose signature is ``marks``: where a past pixel saw the
    same surface (:func:`gmcpt.temporal.history.matches`) under the same light and material
    (:func:`gmcpt.temporal.history.unchanged`), its samples count ``weight``; where the camera moved, a frame that
    kept its samples by quarter gives those that fell within the pixel (:func:`_by_quarters`). A frame whose camera
    did not move and whose meshes did not (``then`` None) lands each point on its own past pixel, which alone is read
    (:func:`_match`'s ``nearest_only``)."""
    pixels = positions.shape[0]
    point, normal, current = _vector(positions, mi.Point3f), _vector(normals, mi.Vector3f), _marks(marks)
    floor = dr.opaque(mi.Float, float(lighting_floor))
    summed = [dr.zeros(mi.Float, pixels) for _ in range(4)]
    offered, lighting_dropped, material_dropped = (dr.zeros(mi.Bool, pixels) for _ in range(3))
    latest_seen, latest_film = np.zeros(pixels, bool), np.zeros((pixels, 2), np.float32)
    for frame, weight, latest, camera_moved, then in frames:
        point_then, normal_then = (point, normal) if then is None else (
            _vector(then[0], mi.Point3f), normal if then[1] is None else _vector(then[1], mi.Vector3f))
        # a still camera's points land on their own past pixels, unless a mesh moved (then): the nearest alone serves
        match = _match(frame, point_then, normal_then, current, floor, camera_moved,
                       nearest_only=not camera_moved and then is None)
        if camera_moved and frame.quarters is not None:
            taken = _by_quarters(frame, match)
        else:
            taken = [dr.select(match.held, dr.gather(mi.Float, values, match.source, match.held), 0.0)
                     for values in frame.samples]
        scale = dr.opaque(mi.Float, float(weight))
        summed = [total + value * scale for total, value in zip(summed, taken)]
        offered |= match.offered
        lighting_dropped |= ~match.held & ~match.lit
        material_dropped |= ~match.held & match.lit & ~match.same_material
        outputs = [*summed, offered, lighting_dropped, material_dropped] + \
            ([match.held, match.u, match.v] if latest else [])
        dr.eval(*outputs)  # one kernel a past frame, all its outputs together
        if latest:
            latest_seen = np.asarray(match.held, bool)
            latest_film = np.stack([np.asarray(match.u, np.float32), np.asarray(match.v, np.float32)], axis=1)
    return Gathered(np.stack([np.asarray(total, np.float32) for total in summed], axis=1), np.asarray(offered, bool),
                    np.asarray(lighting_dropped, bool), np.asarray(material_dropped, bool), latest_seen,
                    np.where(latest_seen[:, None], latest_film, np.float32(0)))


#: The four past pixels whose centres surround a point, as (column, row) steps from the top left one
_AROUND = ((0, 0), (1, 0), (0, 1), (1, 1))


@dataclass(frozen=True)
class _Match:
    """Where a past frame's samples serve each current pixel (:func:`_match`), Dr.Jit arrays over the pixels."""

    held: mi.Bool  # its history held
    source: mi.UInt32  # the past pixel it comes from
    offered: mi.Bool  # some past pixel of the four around the point saw its surface
    lit: mi.Bool  # the nearest such one's lighting held
    same_material: mi.Bool  # ... and its albedo
    u: mi.Float  # where the point lands on the past film
    v: mi.Float
    left: mi.Float  # the top left of the four past pixels around the point
    top: mi.Float
    around: tuple  # for each of the four (:data:`_AROUND`): (its flat index, whether its light and albedo held)
    quartered: mi.Bool  # where the samples by quarter may serve (:func:`_by_quarters`)


def _match(frame: JitFrame, point: mi.Point3f, normal: mi.Vector3f, current: tuple, floor: mi.Float,
           camera_moved: bool, nearest_only: bool = False) -> _Match:
    """Where ``frame``'s samples serve each current pixel.

    The past pixel the point lands in decides where it saw the same surface (:func:`~gmcpt.temporal.history.matches`,
    :func:`~gmcpt.temporal.history.unchanged`); where it saw another surface and the camera moved (the point is near
    an edge), the nearest other of the four past pixels around the point that saw this one and passes the same tests
    serves. An edge then keeps its history as a still camera's does (nearest-pixel alone dropped it on every edge of a
    pan, where the error concentrates); changed light or albedo at the nearest past pixel is never outvoted by
    another, and a still camera's other surface is an object that moved, whose surroundings' light changed unseen
    (serving neighbours there cost the living room's moving table 0.45 dB on its changed pixels).

    By quarter (:func:`_by_quarters`), a past pixel serves where its light and albedo held whatever surface its centre
    saw: a pixel across a silhouette sees both surfaces, and its signature is the mean over them. Where the nearest
    saw this surface and failed the tests, none does, nor where none of the four saw it (a disocclusion, a cut).

    ``nearest_only`` (a camera that stayed, no mesh moved): the nearest alone is read, which keeps, drops and reads
    from what the four do (the others serve only where the point is off its centre), in 3 of a frame's 8 ms (the
    breakfast light); ``offered`` is then the nearest's own (the others' can differ only at a surface that moved)."""
    m = frame.matrix
    x = m[0] * point.x + m[1] * point.y + m[2] * point.z + m[3]
    y = m[4] * point.x + m[5] * point.y + m[6] * point.z + m[7]
    depth = m[8] * point.x + m[9] * point.y + m[10] * point.z + m[11]
    front = depth > 1e-9
    safe = dr.select(front, depth, 1.0)
    u, v = x / safe, y / safe
    left, top = dr.floor(u - 0.5), dr.floor(v - 0.5)  # the 2x2 past pixels whose centres surround the point
    fx, fy = u - 0.5 - left, v - 0.5 - top
    # how far the camera moved the point off the nearest past centre: every one of the four is judged by it, so a
    # still camera's neighbour (at a moved object's edge) gets no allowance for a shift that did not happen; a camera
    # that moved by whole pixels lands on the centres as a still one does, and is told apart by ``camera_moved``
    landed_column, landed_row = dr.floor(u), dr.floor(v)  # the past pixel the point lands in: the nearest centre
    offset = dr.maximum(dr.abs(u - landed_column - 0.5), dr.abs(v - landed_row - 0.5))
    shifted = dr.minimum(2 * offset, 1.0)
    moved = (offset > SHIFT_SEEN) | (dr.opaque(mi.Float, 1.0 if camera_moved else 0.0) > 0)
    if nearest_only:
        source, _, same, lit, material = _tap(frame, landed_column, landed_row, front, point, normal, current, floor,
                                              shifted, moved)
        held = same & lit & material
        return _Match(held, source, same, dr.select(same, lit, True), dr.select(same, material, True), u, v, left,
                      top, (), held)
    lanes = dr.width(point.x)
    near_same, near_lit, near_material = (dr.zeros(mi.Bool, lanes) for _ in range(3))
    any_same, near_source = dr.zeros(mi.Bool, lanes), dr.zeros(mi.UInt32, lanes)
    other_weight, other_source = dr.zeros(mi.Float, lanes), dr.zeros(mi.UInt32, lanes)
    around = []
    for dx, dy in _AROUND:
        column, row = left + dx, top + dy
        source, inside, same, lit, material = _tap(frame, column, row, front, point, normal, current, floor, shifted,
                                                   moved)
        around.append((source, inside & lit & material))
        weight = (fx if dx else 1 - fx) * (fy if dy else 1 - fy)
        nearest = (column == landed_column) & (row == landed_row)
        near_same |= nearest & same
        near_lit |= nearest & same & lit
        near_material |= nearest & same & material
        near_source = dr.select(nearest, source, near_source)
        closer = ~nearest & same & lit & material & (weight > other_weight)
        other_weight, other_source = dr.select(closer, weight, other_weight), dr.select(closer, source, other_source)
        any_same |= same
    # a still camera's nearest past pixel is the pixel itself: another surface there is an object that moved, whose
    # neighbours' light (what it shadowed or lit around it) the signature does not see
    held = dr.select(near_same, near_lit & near_material, moved & (other_weight > 0))
    return _Match(held, dr.select(near_same, near_source, other_source), any_same,
                  dr.select(near_same, near_lit, True), dr.select(near_same, near_material, True), u, v, left, top,
                  tuple(around), held | (moved & ~near_same & any_same))


def _tap(frame: JitFrame, column, row, front: mi.Bool, point: mi.Point3f, normal: mi.Vector3f, current: tuple,
         floor: mi.Float, shifted: mi.Float, moved: mi.Bool) -> tuple:
    """``frame``'s pixel at ``column``, ``row`` (mi.Float each) for each lane: (its flat index, whether it is on the
    film, whether it saw the point's surface (:func:`~gmcpt.temporal.history.matches`), whether its lighting held and
    whether its albedo held (:func:`~gmcpt.temporal.history.unchanged`), whatever surface it saw)."""
    inside = front & (column >= 0) & (column < frame.width) & (row >= 0) & (row < frame.height)
    source = dr.select(inside, mi.UInt32(dr.maximum(row, 0)) * frame.width + mi.UInt32(dr.maximum(column, 0)), 0)
    past_point = dr.gather(mi.Point3f, frame.positions, source, inside)
    past_normal = dr.gather(mi.Vector3f, frame.normals, source, inside)
    step, away = past_point - point, point - frame.centre
    same = inside & (dr.squared_norm(step) <= DEPTH_TOLERANCE ** 2 * dr.squared_norm(away)) & \
        (dr.dot(past_normal, normal) >= NORMAL_COSINE)
    held = []
    for mine, theirs, my_spread, their_spread, ratio, margin in (
            (current[0], frame.marks[0], current[2], frame.marks[2], LIGHTING_RATIO, floor),
            (current[1], frame.marks[1], current[3], frame.marks[3], 0.0, ALBEDO_MARGIN)):
        theirs = dr.gather(mi.Float, theirs, source, inside)
        spread = dr.maximum(shifted * dr.maximum(my_spread, dr.gather(mi.Float, their_spread, source, inside)),
                            dr.select(moved, my_spread, 0.0))
        held.append(dr.abs(mine - theirs) <= spread + ratio * dr.maximum(mine, theirs) + margin)
    return source, inside, same, held[0], held[1]


def _by_quarters(frame: JitFrame, match: _Match) -> list:
    """R, G, B sums and count of ``frame``'s samples that fell within each current pixel's footprint, to a quarter
    pixel: its footprint on the past film, a pixel square about the point, holds four quarter centres, each in one of
    the four past pixels around the point, which serves if its light and albedo held (:func:`_match`). Nearest-pixel
    reads take a past pixel's samples up to half a pixel off: at an edge another mix of its two sides (on a pan at
    half a pixel a frame, 0.2 dB at 4 samples a pixel; docs/experiments.md)."""
    summed = [dr.zeros(mi.Float, dr.width(match.u)) for _ in range(4)]
    # quarter centres lie at k / 2 + 1 / 4: the first of the two within [u - 1/2, u + 1/2) on each axis
    first_x, first_y = dr.ceil(2 * match.u - 1.5), dr.ceil(2 * match.v - 1.5)
    for step_x, step_y in _AROUND:
        x, y = first_x + step_x, first_y + step_y
        column, row = dr.floor(x / 2), dr.floor(y / 2)
        quarter = mi.UInt32(x - 2 * column) + 2 * mi.UInt32(y - 2 * row)
        serves, pixel = dr.zeros(mi.Bool, dr.width(x)), dr.zeros(mi.UInt32, dr.width(x))
        for (dx, dy), (source, passes) in zip(_AROUND, match.around):
            here = (column - match.left == dx) & (row - match.top == dy)
            serves |= here & passes
            pixel = dr.select(here, source, pixel)
        serves &= match.quartered
        index = pixel * 4 + quarter
        summed = [total + dr.select(serves, dr.gather(mi.Float, values, index, serves), 0.0)
                  for total, values in zip(summed, frame.quarters)]
    return summed


def cubic_sample(image: np.ndarray, film: np.ndarray) -> np.ndarray:
    """``image`` (H, W, C) read at film coordinates ``film`` (N, 2; pixel centres at +0.5, within the film) with
    Catmull-Rom weights over 4x4 pixels, edges replicated, clipped at 0: (N, C) float32. Sharper than bilinear,
    so an image carried from frame to frame this way does not grow blurred (bilinear lost 0.3 dB over a pan). One
    kernel (numpy's 16 gathers a channel took 14 ms of a 256x256 frame)."""
    height, width, channels = image.shape
    planes = [_float(image[..., channel]) for channel in range(channels)]
    x, y = _float(film[:, 0]) - 0.5, _float(film[:, 1]) - 0.5
    left, top = dr.floor(x), dr.floor(y)
    weights_x, weights_y = _catmull_rom(x - left), _catmull_rom(y - top)
    columns = [mi.UInt32(dr.clip(left + i - 1, 0, width - 1)) for i in range(4)]
    rows = [mi.UInt32(dr.clip(top + j - 1, 0, height - 1)) * width for j in range(4)]
    totals = [dr.zeros(mi.Float, film.shape[0]) for _ in range(channels)]
    for row, weight_y in zip(rows, weights_y):
        for column, weight_x in zip(columns, weights_x):
            index, weight = row + column, weight_y * weight_x
            totals = [total + dr.gather(mi.Float, plane, index) * weight for total, plane in zip(totals, planes)]
    totals = [dr.maximum(total, 0.0) for total in totals]
    dr.eval(*totals)
    return np.stack([np.asarray(total, np.float32) for total in totals], axis=1)


def _catmull_rom(t):
    """The four Catmull-Rom weights of the taps at -1, 0, 1, 2 for a fraction ``t`` in [0, 1)."""
    t2, t3 = t * t, t * t * t
    return [(-t3 + 2 * t2 - t) / 2, (3 * t3 - 5 * t2 + 2) / 2, (-3 * t3 + 4 * t2 + t) / 2, (t3 - t2) / 2]
