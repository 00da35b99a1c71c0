"""Shapes that move between a sequence's frames, and where a surface point of one was on an earlier frame.

Mitsuba moves a mesh through ``mi.traverse`` (or a scene loaded again with other ``$`` parameters) by giving it new
vertex positions. :class:`ShapePoses` reads, each frame, which meshes' bounding boxes changed, fits the affine map
from their last vertices to their new ones (:func:`affine_fit`), and keeps each mesh's pose: the map from where it
was on the first frame it saw. A pixel whose centre ray hit a moved mesh then takes its history from where that point
was on each past frame (:func:`points_then`), so the history of a moving object goes with it, where before it took
the past frames' samples of the same pixel: another part of the object, or what was behind it, as long as it lay
within the depth test (the living room's moving table smeared its legs).
"""
from __future__ import annotations

import drjit as dr
import mitsuba as mi
import numpy as np

#: At most this many vertices of a mesh are read to fit its motion (evenly spread over its buffer): a rigid or
#: affine motion needs four, and the table of the living room has tens of thousands.
FIT_VERTICES = 4096


def shape_keys(scene: mi.Scene) -> np.ndarray:
    """For each Dr.Jit registry index of a shape of ``scene`` (what a ray's ``si.shape`` holds), the shape's place in
    ``scene.shapes()``, -1 elsewhere: the place stays when the scene is loaded again, the registry index does not."""
    registry = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in scene.shapes()]
    keys = np.full(max(registry, default=0) + 1, -1, np.int64)
    keys[registry] = np.arange(len(registry))
    return keys


def affine_fit(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """The (4, 4) affine map that takes the points ``before`` (V, 3) to ``after`` (V, 3), least squares; the
    translation of their centroids where ``before`` spans no volume (a flat or thin mesh: its map across the plane is
    not known, and a guess there could not be inverted)."""
    matrix = np.eye(4)
    centre_before, centre_after = before.mean(axis=0), after.mean(axis=0)
    spread = np.linalg.svd(before - centre_before, compute_uv=False) if before.shape[0] >= 4 else np.zeros(1)
    if spread.size < 3 or spread[-1] <= 1e-6 * max(spread[0], 1e-12):
        matrix[:3, 3] = centre_after - centre_before
        return matrix
    ones = np.ones((before.shape[0], 1))
    solution, *_ = np.linalg.lstsq(np.concatenate([before, ones], axis=1), after, rcond=None)
    matrix[:3] = solution.T
    return matrix


def _vertices(mesh: mi.Mesh, buffer) -> np.ndarray:
    """Up to :data:`FIT_VERTICES` vertices of ``mesh`` (its positions ``buffer``, flat xyz, Dr.Jit's or a resumed
    state's numpy; or those already chosen, (V, 3)), (V, 3) float64. The whole buffer is read: a gather of the chosen
    ones launched a kernel a mesh, slower on the living room's table (7 meshes, 7.6 ms a frame against 5.7)."""
    if isinstance(buffer, np.ndarray) and buffer.ndim == 2:
        return buffer
    count = mesh.vertex_count()
    chosen = np.unique(np.linspace(0, count - 1, min(count, FIT_VERTICES)).astype(np.int64))
    return np.asarray(buffer, np.float64).reshape(-1, 3)[chosen]


class ShapePoses:
    """Each mesh's pose on the frames so far (:meth:`update`): the (4, 4) map from where it was on the first frame
    seen, for the meshes that moved since, by their place in ``scene.shapes()``."""

    def __init__(self):
        self.poses: dict[int, np.ndarray] = {}
        # each mesh's bounding box and vertex buffer on the last frame (the buffer held, not copied: an update gives
        # the mesh a new one, and the old one is what its motion is read from), or for one that moved the vertices
        # its motion was fitted on
        self._last: dict[int, tuple] = {}
        self._count = 0  # the shapes of the last frame's scene

    def update(self, scene: mi.Scene) -> dict[int, np.ndarray]:
        """The poses on ``scene``'s frame, after reading which meshes moved since the last frame."""
        shapes = scene.shapes()
        last, self._last = self._last, {}
        if last and len(shapes) != self._count:  # another scene (a cut): its shapes are not the last one's
            last, self.poses = {}, {}
        self._count = len(shapes)
        for key, shape in enumerate(shapes):
            if not isinstance(shape, mi.Mesh):
                continue
            box = shape.bbox()
            corners = (tuple(float(value) for value in box.min), tuple(float(value) for value in box.max))
            buffer = shape.vertex_positions_buffer()
            self._last[key] = (corners, (shape.id(), shape.vertex_count()), buffer)
            before = last.get(key)
            if before is None or before[0] == corners or before[1] != self._last[key][1]:
                continue
            now = _vertices(shape, buffer)
            self.poses[key] = affine_fit(_vertices(shape, before[2]), now) @ self.poses.get(key, np.eye(4))
            self._last[key] = (*self._last[key][:2], now)  # a mesh that moves reads one buffer a frame, not two
        return dict(self.poses)

    def state(self) -> dict[str, np.ndarray]:
        """The last frame's vertices of the meshes that moved (for :func:`numpy.savez`): what :meth:`restore` takes
        back with the last frame's poses (:attr:`gmcpt.temporal.history.PastFrame.poses`, saved with it), so that a
        resumed sequence reads the next frame's motion as an uninterrupted one does (a mesh that never moved is read
        as moving from the frame after it first does)."""
        state = {"mesh_count": np.array(self._count)}
        for key in sorted(set(self.poses) & set(self._last)):
            (low, high), (name, count), buffer = self._last[key]
            state[f"mesh_{key}_box"] = np.array([low, high], np.float64)
            state[f"mesh_{key}_name"], state[f"mesh_{key}_count"] = np.array(name), np.array(count)
            state[f"mesh_{key}_vertices"] = np.asarray(buffer)
        return state

    def restore(self, state, poses: dict[int, np.ndarray]) -> None:
        """Take back a :meth:`state` and the ``poses`` of the frame it was saved after (an older state without
        one: the next frame reads no motion)."""
        self.poses = dict(poses)
        self._last = {key: ((tuple(state[f"mesh_{key}_box"][0]), tuple(state[f"mesh_{key}_box"][1])),
                            (str(state[f"mesh_{key}_name"]), int(state[f"mesh_{key}_count"])),
                            state[f"mesh_{key}_vertices"]) for key in poses if f"mesh_{key}_box" in state}
        self._count = int(state["mesh_count"]) if "mesh_count" in state else 0


def points_then(positions: np.ndarray, normals: np.ndarray, lanes: dict[int, np.ndarray], now: dict[int, np.ndarray],
                then: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray | None] | None:
    """Where the surface points ``positions`` (N, 3) with ``normals``, on the meshes whose pixels ``lanes`` lists (a
    mesh's place in ``scene.shapes()`` -> its pixels) at poses ``now``, were at poses ``then``: (positions, normals,
    None where no mesh turned) float32, or None where no mesh of the frame moved between the two."""
    identity = np.eye(4)
    moved = [key for key in lanes if not np.array_equal(now.get(key, identity), then.get(key, identity))]
    if not moved:
        return None
    positions, turned = positions.copy(), None
    for key in moved:
        on = lanes[key]
        step = then.get(key, identity) @ np.linalg.inv(now.get(key, identity))
        linear = step[:3, :3]
        positions[on] = positions[on] @ linear.T.astype(np.float32) + step[:3, 3].astype(np.float32)
        if not np.allclose(linear, np.eye(3), rtol=0, atol=1e-7):
            turned = normals.copy() if turned is None else turned
            rotated = normals[on] @ np.linalg.inv(linear).astype(np.float32)  # normals by the inverse transpose
            turned[on] = rotated / np.maximum(np.linalg.norm(rotated, axis=1, keepdims=True), np.float32(1e-12))
    return positions, turned
