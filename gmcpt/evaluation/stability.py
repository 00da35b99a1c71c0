"""Temporal stability of a sequence's frames: the flicker figures of ``benchmarks/sequence.py``.

Both compare the displayed frames' changes with the references' changes, so an image that follows the scene
scores 0 whatever its error, and one whose error is new every frame scores about sqrt(2) x its RMS error:

- :func:`screen_flicker` takes each pixel's change in place. On a moving camera the scene slides across the
  pixels, so an error that stays on its surface (a blurred edge, a missing highlight) still changes in place:
  it counts as flicker though nothing flickers.
- :func:`surface_flicker` takes each pixel's change along the motion: the frame before is read where this
  pixel's surface point was (bilinear, from the cameras and the centre rays' hits), and pixels whose point
  was hidden or off the film are left out. This is the warping error of video consistency work (Lai et al.,
  ECCV 2018, with exact motion for optical flow): what a viewer sees as flicker.

A reference has noise of its own, new every frame, which adds to every contender's figure alike (512 samples a
pixel in the living room: 3.8 of a figure near 6). Given a ``second`` reference of each frame, independent of
the first, the figures are read from the product of the errors against the two, whose mean is the squared error
against the noise-free changes: the floor is gone, not subtracted by a guess.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..metrics import tonemap
from ..temporal import PastFrame, Projection, reproject


@dataclass(frozen=True)
class FrameGeometry:
    """Where each pixel's centre ray hit (N, 3; NaN on a miss), the normals there, and the frame's camera."""

    positions: np.ndarray
    normals: np.ndarray
    projection: Projection


def screen_flicker(images: list[np.ndarray], references: list[np.ndarray],
                   second: list[np.ndarray] | None = None) -> float:
    """100 x the RMS over frames and pixels of the error of in-place frame-to-frame changes (tonemapped)."""
    return _figure(images, references, second, lambda error, t: (error[t] - error[t - 1]).reshape(-1))


def surface_flicker(images: list[np.ndarray], references: list[np.ndarray], geometries: list[FrameGeometry],
                    second: list[np.ndarray] | None = None) -> float:
    """100 x the RMS over frames and pixels seen in both of the error of frame-to-frame changes along the
    motion (tonemapped): ``(a_t - warp(a_t-1)) - (r_t - warp(r_t-1))``."""
    if len(geometries) != len(images):
        raise ValueError("one geometry a frame")
    shape = images[0].shape[:2]
    motions = [None] + [_motion(geometries[t - 1], geometries[t], shape) for t in range(1, len(images))]

    def change(error, t):
        before, seen = _warped(error[t - 1], motions[t])
        return (error[t].reshape(before.shape) - before)[seen].reshape(-1)

    return _figure(images, references, second, change)


def _figure(images, references, second, change) -> float:
    """100 x sqrt of the mean over frames 1.. of ``change(errors, t)`` squared, or of its product over the two
    references' errors when a ``second`` is given (clipped at 0: the estimate of a near-zero figure can dip
    below it)."""
    second = references if second is None else second
    if not len(images) == len(references) == len(second):
        raise ValueError("one reference a frame")
    shown = [tonemap(i) for i in images]
    errors = [[a - tonemap(r) for a, r in zip(shown, refs)] for refs in (references, second)]
    products, count = 0.0, 0
    for t in range(1, len(shown)):
        first, other = change(errors[0], t), change(errors[1], t)
        products += float(np.dot(first, other))
        count += first.size
    return 100 * float(np.sqrt(max(products / max(count, 1), 0.0)))


def _motion(past: FrameGeometry, current: FrameGeometry, shape: tuple[int, int]) -> tuple:
    """Where each ``current`` pixel's surface point lies on the ``past`` film of ``shape`` (H, W), once for every
    image read there (:func:`_warped`): (seen (N,) bool: the point was in view in the past frame, by the depth and
    normal tests of :func:`gmcpt.temporal.matches`, with all four bilinear taps on the film; the top-left tap's
    column and row (N,); the fractions (N, 1) each)."""
    height, width = shape
    frame = PastFrame(0, np.zeros((height * width, 3)), np.zeros(height * width), past.positions, past.normals,
                      past.projection)
    _, seen = reproject(frame, current.positions, current.normals)
    film, _ = past.projection.project(np.nan_to_num(current.positions.astype(np.float64)))
    x, y = film[:, 0] - 0.5, film[:, 1] - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    seen &= (x0 >= 0) & (x0 + 1 < width) & (y0 >= 0) & (y0 + 1 < height)
    x0, y0 = np.clip(x0, 0, width - 2).astype(np.int64), np.clip(y0, 0, height - 2).astype(np.int64)
    return seen, x0, y0, np.clip(x - x0, 0, 1)[:, None], np.clip(y - y0, 0, 1)[:, None]


def _warped(image: np.ndarray, motion: tuple) -> tuple[np.ndarray, np.ndarray]:
    """``image`` (H, W, C) read bilinearly at a :func:`_motion`: ((N, C) values, seen (N,))."""
    seen, x0, y0, fx, fy = motion
    width = image.shape[1]
    flat = image.reshape(-1, image.shape[2])
    top = flat[y0 * width + x0] * (1 - fx) + flat[y0 * width + x0 + 1] * fx
    bottom = flat[(y0 + 1) * width + x0] * (1 - fx) + flat[(y0 + 1) * width + x0 + 1] * fx
    return top * (1 - fy) + bottom * fy, seen
