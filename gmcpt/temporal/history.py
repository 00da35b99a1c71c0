"""Reusing the samples of earlier frames: projection, reprojection and the history's weights, pure numpy.

Each earlier frame is kept as it was traced (:class:`PastFrame`: its own samples' sums, where each pixel's
centre ray hit, and its camera) and is reprojected straight into the current frame, never through the frames
between: a sample is moved once, to the nearest pixel, so the history is neither blurred nor its noise
correlated as repeated bilinear resampling does (issue 49's trap). A past pixel serves a current one only where
the current pixel's surface point lands in the past pixel (within half a pixel of its centre), on the same
surface (positions within :data:`DEPTH_TOLERANCE` of the distance, normals within :data:`NORMAL_COSINE`), so
disocclusions and camera cuts get no history; and only while it agrees with the current frame's own samples
(:func:`agreement`), so moving lights and objects do not smear.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..errors import GmcptError

#: Largest gap between the past and current surface points, relative to the current point's distance.
DEPTH_TOLERANCE = 0.02
#: Least cosine between the past and current shading normals.
NORMAL_COSINE = 0.9
#: History whose luminance over a 15x15 neighbourhood differs from the current samples' by more than this factor
#: is left out (a light or an object that changed): wide enough that one or two samples' noise does not drop good
#: history (3 dropped 6% of a pan's at budget 1), the lighting signature catching changed light.
DISAGREE_RATIO = 5.0
DISAGREE_RADIUS = 7
#: A pixel's luminance counts in the test up to this many times its image's mean: one firefly among a frame's
#: few samples is no changed light (unclipped, the dining room's pan lost 6-9% of its history to them).
DISAGREE_CLIP = 4.0
#: A past pixel's history is kept only where its lighting signature (:func:`gmcpt.temporal.survey.survey`: direct
#: light through fixed light samples, the same every frame) and the current pixel's differ by at most this share of the
#: larger, :data:`LIGHTING_FLOOR` x the frame's mean and what a sub-pixel shift explains (:func:`unchanged`): a
#: shadow that moved, a light switched or moved, a highlight that slid.
LIGHTING_RATIO = 0.08
LIGHTING_FLOOR = 0.02
#: A point that lands this far (pixels) or more off a past pixel's centre was seen by a camera that moved
#: (:func:`unchanged`); a still camera's land on the centres to float rounding.
SHIFT_SEEN = 0.01
#: The same test on the guides' albedo (a changed material, the edge of an object that moved over its background),
#: with an absolute margin: albedos are within [0, 1].
ALBEDO_MARGIN = 0.05


@dataclass(frozen=True)
class Projection:
    """A pinhole camera as a 3x4 matrix from world points to film pixels (x right, y down, pixel centres at
    +0.5), fitted from its rays (:func:`fit_projection`)."""

    matrix: np.ndarray  # (3, 4)
    width: int
    height: int

    @functools.cached_property
    def centre(self) -> np.ndarray:
        """The pinhole: the null vector of the matrix (infinite for a camera without one)."""
        _, _, vt = np.linalg.svd(self.matrix)
        with np.errstate(divide="ignore", invalid="ignore"):
            return vt[-1][:3] / vt[-1][3]

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(film coordinates (N, 2), in front of the camera (N,) bool) of world ``points``, (N, 3) or homogeneous
        (N, 4), in their own precision."""
        if points.shape[1] == 3:
            points = np.concatenate([points, np.ones((points.shape[0], 1), points.dtype)], axis=1)
        # einsum's own loop, not BLAS: a matrix product on this frame would wake OpenBLAS's threads (gmcpt/__init__)
        homogeneous = np.einsum("ij,kj->ik", points, self.matrix.astype(points.dtype))
        depth = homogeneous[:, 2]
        front = depth > 1e-9
        safe = np.where(front, depth, 1.0)
        return homogeneous[:, :2] / safe[:, None], front


def fit_projection(film: np.ndarray, origins: np.ndarray, directions: np.ndarray, width: int,
                   height: int) -> Projection:
    """The :class:`Projection` through rays from ``origins`` along ``directions`` (N, 3 each) that leave the
    camera at film coordinates ``film`` (N, 2): a direct linear fit on two points along each ray.

    Raises a one-line :class:`GmcptError` when the rays do not meet in one point as a pinhole camera's do (a
    thin lens, an orthographic or a panoramic camera): sequences need a pinhole camera.
    """
    points = np.concatenate([origins + directions, origins + 4.0 * directions])
    pixels = np.concatenate([film, film])
    rows = []
    for (x, y, z), (u, v) in zip(points, pixels):
        rows.append([x, y, z, 1, 0, 0, 0, 0, -u * x, -u * y, -u * z, -u])
        rows.append([0, 0, 0, 0, x, y, z, 1, -v * x, -v * y, -v * z, -v])
    _, _, vt = np.linalg.svd(np.asarray(rows, np.float64), full_matrices=False)
    matrix = vt[-1].reshape(3, 4)
    if (points @ matrix[2, :3] + matrix[2, 3]).mean() < 0:
        matrix = -matrix
    projection = Projection(matrix, width, height)
    landed, front = projection.project(points)
    pinhole = np.isfinite(projection.centre).all() and np.abs(projection.centre).max() < 1e12
    if not pinhole or not front.all() or np.abs(landed - pixels).max() > 1e-3 * max(width, height):
        raise GmcptError("a sequence needs a pinhole (perspective) camera: this sensor's rays do not meet in a point")
    return projection


@dataclass
class PastFrame:
    """One earlier frame as it was traced: its own samples only (flat sums), and its geometry."""

    index: int  # the frame's number in the sequence
    total: np.ndarray  # (N, 3) sum of its radiance samples
    count: np.ndarray  # (N,) its finite samples
    positions: np.ndarray  # (N, 3) where each pixel's centre ray hit (NaN on a miss)
    normals: np.ndarray  # (N, 3)
    projection: Projection
    signature: "Signature | None" = None  # its lighting and albedo (for :func:`unchanged`)
    #: (N, 4, 4) its samples' sums by the pixel's quarter they fell in (R, G, B, count; left top, right top, left
    #: bottom, right bottom), or None (a frame of Mitsuba's film: where in the pixel is not known)
    quarters: "np.ndarray | None" = None
    #: the poses of the meshes that had moved by this frame (:class:`~gmcpt.temporal.motion.ShapePoses`), or None
    poses: "dict | None" = None

    def arrays(self) -> dict[str, np.ndarray]:
        """The frame as plain arrays (for :func:`numpy.savez`): what :meth:`from_arrays` takes back."""
        arrays = {"index": np.array(self.index), "total": self.total, "count": self.count,
                  "positions": self.positions, "normals": self.normals,
                  "lighting": self.signature.lighting, "albedo": self.signature.albedo,
                  "matrix": self.projection.matrix, "size": np.array([self.projection.width, self.projection.height])}
        if self.quarters is not None:
            arrays["quarters"] = self.quarters
        if self.poses:
            arrays["pose_shapes"] = np.array(sorted(self.poses))
            arrays["poses"] = np.stack([self.poses[key] for key in sorted(self.poses)])
        return arrays

    @classmethod
    def from_arrays(cls, arrays) -> "PastFrame":
        """The frame :meth:`arrays` gave (a dict, or an open ``.npz``)."""
        width, height = (int(value) for value in arrays["size"])
        poses = dict(zip((int(key) for key in arrays["pose_shapes"]), arrays["poses"])) if "poses" in arrays else None
        return cls(int(arrays["index"]), arrays["total"], arrays["count"], arrays["positions"], arrays["normals"],
                   Projection(arrays["matrix"], width, height),
                   signature(arrays["lighting"], arrays["albedo"], width, height),
                   arrays["quarters"] if "quarters" in arrays else None, poses)


@dataclass(frozen=True)
class Surfaces:
    """The current frame's centre-ray hits, made once (:func:`surfaces`) for every past frame's :func:`matches`."""

    pixels: np.ndarray  # (M,) flat indices of the pixels whose ray hit
    points: np.ndarray  # (M, 4) where, homogeneous
    normals: np.ndarray  # (M, 3)
    size: int  # pixels in the frame


def surfaces(positions: np.ndarray, normals: np.ndarray) -> Surfaces:
    """:class:`Surfaces` of ``positions`` and ``normals`` ((N, 3) each, NaN on a miss)."""
    pixels = np.flatnonzero(np.isfinite(positions[:, 0]))
    points = np.concatenate([positions[pixels], np.ones((pixels.size, 1), positions.dtype)], axis=1)
    return Surfaces(pixels, points, normals[pixels], positions.shape[0])


def matches(past: PastFrame, current: Surfaces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(current pixels (K,), the past pixels (K,) that saw the same surface points, where on the past film the
    points landed (K, 2)). The past pixel is the one the point lands in, so its centre is within half a pixel;
    no match for a miss, a point off the past film or behind its camera, or another surface there (depth or
    normal)."""
    projection = past.projection
    film, front = projection.project(current.points)
    column, row = np.floor(film[:, 0]), np.floor(film[:, 1])
    inside = np.flatnonzero(front & (column >= 0) & (column < projection.width) & (row >= 0)
                            & (row < projection.height))
    source = row[inside].astype(np.int64) * projection.width + column[inside].astype(np.int64)
    points = current.points[inside, :3]
    step = past.positions[source] - points
    away = points - projection.centre.astype(points.dtype)
    same = (np.einsum("ij,ij->i", step, step) <= DEPTH_TOLERANCE ** 2 * np.einsum("ij,ij->i", away, away)) & \
        (np.einsum("ij,ij->i", past.normals[source], current.normals[inside]) >= NORMAL_COSINE)
    return current.pixels[inside[same]], source[same], film[inside[same]]


@dataclass(frozen=True)
class Signature:
    """A frame's lighting signature and albedo luminance (N,) each at its pixels, and how much each varies over the
    pixel's 3x3 neighbourhood (greatest less least): what :func:`unchanged` compares."""

    lighting: np.ndarray
    albedo: np.ndarray
    lighting_spread: np.ndarray
    albedo_spread: np.ndarray


def signature(lighting: np.ndarray, albedo: np.ndarray, width: int, height: int) -> Signature:
    """The :class:`Signature` of a ``width`` x ``height`` frame's flat ``lighting`` and ``albedo`` (N,)."""
    spreads = [np.subtract(*_neighbourhood_range(values, width, height)[::-1]) for values in (lighting, albedo)]
    return Signature(lighting, albedo, *spreads)


def unchanged(past: Signature, source: np.ndarray, current: Signature, pixels: np.ndarray, film: np.ndarray,
              lighting_floor: float, camera_moved: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(lighting held, albedo held) (K,) bool each, for the current ``pixels`` (K,) that :func:`matches` paired
    with ``past`` pixels ``source`` (K,), landing at ``film`` (K, 2) on the past film.

    The two frames' values may differ by :data:`LIGHTING_RATIO` of the larger (:data:`ALBEDO_MARGIN` for the
    albedo), by ``lighting_floor`` (:data:`LIGHTING_FLOOR` x the current frame's mean, so that the dark does not
    count its rounding), and by as much of their neighbourhoods' spread as the point landed off the past pixel's
    centre (none at the centre, all of it half a pixel off): a still camera compares like with like, and a moving
    one allows what a sub-pixel shift across an edge changes. Where the point landed off the centre at all
    (:data:`SHIFT_SEEN`), or wherever ``camera_moved`` (a camera that moved by whole pixels lands on the centres
    too), the current pixel's own spread is allowed whole: a signature is the mean of a few guide rays, and any move
    changes which of them fall on either side of an edge (2-5% of a pan's pixels a past frame failed for it, its
    edges). The past pixel's spread stays weighted by the shift: a neighbourhood's range alone let the trailing edge
    of a light that moved by less than a pixel a frame keep its light."""
    offset = np.abs(film - np.floor(film) - np.float32(0.5)).max(axis=1)
    shifted = np.minimum(np.float32(2) * offset, np.float32(1)).astype(np.float32)
    moved = (offset > SHIFT_SEEN) | bool(camera_moved)
    held = []
    for name, ratio, margin in (("lighting", LIGHTING_RATIO, lighting_floor), ("albedo", 0.0, ALBEDO_MARGIN)):
        mine, theirs = getattr(current, name)[pixels], getattr(past, name)[source]
        own_spread = getattr(current, f"{name}_spread")[pixels]
        spread = np.maximum(shifted * np.maximum(own_spread, getattr(past, f"{name}_spread")[source]),
                            np.where(moved, own_spread, np.float32(0)))
        allowed = spread + np.float32(ratio) * np.maximum(mine, theirs) + np.float32(margin)
        held.append(np.abs(mine - theirs) <= allowed)
    return held[0], held[1]


def _neighbourhood_range(values: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(least, greatest) of flat ``values`` (N,) over each pixel's 3x3 neighbourhood on a ``width`` x ``height``
    film (edges replicated), flat float32."""
    plane = np.pad(values.astype(np.float32, copy=False).reshape(height, width), 1, mode="edge")
    ranges = []
    for reduce in (np.minimum, np.maximum):  # separable: rows of three, then columns of three
        rows = reduce(reduce(plane[:-2], plane[1:-1]), plane[2:])
        ranges.append(reduce(reduce(rows[:, :-2], rows[:, 1:-1]), rows[:, 2:]).ravel())
    return ranges[0], ranges[1]


def reproject(past: PastFrame, positions: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`matches` as full arrays: for each current pixel, (the past pixel's flat index, valid) (N,) each."""
    pixels, source, _ = matches(past, surfaces(positions, normals))
    index, valid = np.zeros(positions.shape[0], np.int64), np.zeros(positions.shape[0], bool)
    index[pixels], valid[pixels] = source, True
    return index, valid


def agreement(current_mean: np.ndarray, history_mean: np.ndarray, has_history: np.ndarray) -> np.ndarray:
    """(H, W) bool: where the history's luminance (H, W, 3 means) over a 15x15 neighbourhood is within a factor
    :data:`DISAGREE_RATIO` of the current frame's there (``current_mean``), or there is no history to judge
    (``has_history`` False).

    Wide neighbourhoods and a ratio, not a pixel's own samples against a few standard deviations: a test that
    reads a pixel's own few samples keeps history where they happen to be dark and drops it where they are
    bright, and that selection alone lost 4 dB over five frames of a still camera (docs/experiments.md); a
    15x15 neighbourhood and a factor of 3 dropped 1% of a still camera's history at 2 spp. Each luminance is
    clipped at :data:`DISAGREE_CLIP` x its image's mean, so fireflies do not count as a change.

    No pixel's history is judged alone against its neighbours' current samples: a firefly among the history's
    samples would drop the rest with it, and that selection cost OIDN more than the emitter edges it caught
    (docs/experiments.md, fifty-fifth session).
    """
    current, history = _luminance(current_mean), _luminance(history_mean)
    floor = 0.05 * max(float(current.mean()), 1e-12)  # dark regions: noise, not a changed light
    near = box_sum(np.where(has_history, _clipped(current), 0.0)) + floor
    far = box_sum(np.where(has_history, _clipped(history), 0.0)) + floor
    return ~has_history | ((near <= DISAGREE_RATIO * far) & (far <= DISAGREE_RATIO * near))


def _luminance(image: np.ndarray) -> np.ndarray:
    return np.maximum(np.asarray(image, np.float64).mean(axis=-1), 0.0)


def _clipped(luminance: np.ndarray) -> np.ndarray:
    return np.minimum(luminance, DISAGREE_CLIP * max(float(luminance.mean()), 1e-12))


def box_sum(plane: np.ndarray, radius: int = DISAGREE_RADIUS) -> np.ndarray:
    """Sum over a (2 radius + 1)^2 neighbourhood, edges replicated (a summed-area table)."""
    padded = np.pad(plane, radius, mode="edge")
    table = np.pad(padded.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    size = 2 * radius + 1
    height, width = plane.shape
    return (table[size:size + height, size:size + width] - table[:height, size:size + width]
            - table[size:size + height, :width] + table[:height, :width])


def history_weights(ages: list[int], decay: float) -> list[float]:
    """The weight of each past frame's samples by its age in frames (1: the frame before): ``decay ** age``,
    so recent frames count most."""
    if not 0 < decay <= 1:
        raise GmcptError(f"history decay must be in (0, 1], got {decay}")
    return [decay ** age for age in ages]
