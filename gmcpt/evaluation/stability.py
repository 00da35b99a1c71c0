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

Where a sequence's history goes stale (a moving object's old and new place, its shadow, a moving light's
patches, what a camera move uncovers) is read from the references alone: :func:`changed_pixels` marks those
pixels of a frame, :func:`changed_psnr` reads a contender's PSNR over them only, where a method that keeps stale
history shows it and a whole-frame PSNR dilutes it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..image.metrics import tonemap
from ..temporal.history import PastFrame, Projection, reproject

#: A pixel's change between frames (tonemapped, mean over R, G, B) counts as a change of the scene from this much
#: (:func:`changed_pixels`): 5% of the display range; fainter changes are too faint for stale history to show.
CHANGE_FLOOR = 0.05
#: ... and only where each pair of independent references (each frame's first, each frame's second) changes this
#: many standard deviations of its own noise, the same way: a change of the scene shows in both, a firefly in one
#: reference in one (4 sigma over the two references' mean marked 0.3% of a still room's pixels, scattered over its
#: walls, when its light turned 1 degree: docs/experiments.md).
CHANGE_NOISE_SIGMAS = 3.0
#: The side of the window (pixels) over which a reference's noise is estimated: enough pixels to average out the
#: estimate's own noise, few enough to follow the noise from a lit floor to a dark corner.
NOISE_WINDOW = 7


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


def _motion(past: FrameGeometry, current: FrameGeometry, shape: tuple[int, int], edges: bool = False) -> tuple:
    """Where each ``current`` pixel's surface point lies on the ``past`` film of ``shape`` (H, W), once for every
    image read there (:func:`_warped`): (seen (N,) bool: the point was in view in the past frame, by the depth and
    normal tests of :func:`gmcpt.temporal.history.matches`, with all four bilinear taps on the film; the top-left tap's
    column and row (N,); the fractions (N, 1) each). ``edges``: a point in the film's outer half pixel is seen
    too and reads the edge pixels (else a still camera would lose its last row and column)."""
    height, width = shape
    frame = PastFrame(0, np.zeros((height * width, 3)), np.zeros(height * width), past.positions, past.normals,
                      past.projection)
    _, seen = reproject(frame, current.positions, current.normals)
    film, _ = past.projection.project(np.nan_to_num(current.positions.astype(np.float64)))
    x, y = film[:, 0] - 0.5, film[:, 1] - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    if edges:
        seen &= (film[:, 0] >= 0) & (film[:, 0] < width) & (film[:, 1] >= 0) & (film[:, 1] < height)
    else:
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


def changed_pixels(firsts: list[np.ndarray], seconds: list[np.ndarray], geometries: list[FrameGeometry],
                   frame: int) -> np.ndarray:
    """(N,) bool: the pixels of ``frame`` (>= 1) whose true image changed since the frame before, from the two
    independent references of each frame (``firsts``, ``seconds``: (H, W, 3) linear) and the frames' geometry.

    The mean of a frame's two references is compared with the frame before's, read along the camera's motion
    (bilinear, as :func:`surface_flicker` reads it). A pixel has changed where:

    - its surface point was not in view in the frame before (a disocclusion, or a moved object's new place: its
      points are not where the frame before saw a surface); a miss (the sky through a window) has no point to
      follow and is read in place, as the background is far; or
    - its tonemapped change (the mean over R, G, B) is above :data:`CHANGE_FLOOR` and above
      :data:`CHANGE_NOISE_SIGMAS` standard deviations of the references' noise in it, in the firsts and in the
      seconds alike, with one sign (a moved object's old place, its shadow, a moved light's patches). The noise
      comes from the references themselves: a reference's variance is half the mean squared difference of the two
      (over :data:`NOISE_WINDOW` x :data:`NOISE_WINDOW` pixels), a change's the sum of both frames'.

    Where stale history would show is what this marks: a static noisy area stays out however noisy its
    references, and a pixel that only slid along with the camera is compared with where it was.
    """
    from scipy.ndimage import uniform_filter

    if frame < 1:
        raise ValueError("a frame's change needs the frame before")
    shape = firsts[frame].shape[:2]
    pairs = {t: (_grey(firsts[t]), _grey(seconds[t])) for t in (frame - 1, frame)}
    motion = _motion(geometries[frame - 1], geometries[frame], shape, edges=True)
    miss = np.isnan(geometries[frame].positions).any(axis=1)
    before = np.stack(pairs[frame - 1], axis=-1)  # the firsts and the seconds as two channels: one warp
    warped, seen = _warped(before, motion)
    warped[miss], seen = before.reshape(-1, 2)[miss], seen | miss
    changes = (np.stack(pairs[frame], axis=-1).reshape(-1, 2) - warped).T
    variance = sum(uniform_filter((first - second) ** 2, NOISE_WINDOW, mode="nearest") / 2
                   for first, second in pairs.values())
    # a running sum's rounding leaves a noiseless (black) window's variance a hair below 0: NaN, read as unchanged
    threshold = np.maximum(CHANGE_FLOOR, CHANGE_NOISE_SIGMAS * np.sqrt(np.maximum(variance.reshape(-1), 0.0)))
    both = (np.abs(changes[0]) > threshold) & (np.abs(changes[1]) > threshold) & \
        (np.sign(changes[0]) == np.sign(changes[1]))
    return ~seen | both


def changed_psnr(images: list[np.ndarray], references: list[np.ndarray], masks: list[np.ndarray]) -> float | None:
    """PSNR (dB, tonemapped, peak 1, as :func:`gmcpt.image.metrics.psnr`) over the pixels of ``masks`` ((N,) bool, one a
    frame: :func:`changed_pixels`) of every frame, pooled: one mean squared error over all of them, so that a frame
    with more changed pixels weighs more. None where no pixel changed (a still scene)."""
    if not len(images) == len(references) == len(masks):
        raise ValueError("one reference and one mask a frame")
    squares, count = 0.0, 0
    for image, reference, mask in zip(images, references, masks):
        error = tonemap(image).reshape(-1, 3)[mask].astype(np.float64) - tonemap(reference).reshape(-1, 3)[mask]
        squares += float(np.sum(error ** 2))
        count += error.size
    if count == 0:
        return None
    return float("inf") if squares == 0 else float(10.0 * np.log10(count / squares))


def _grey(image: np.ndarray) -> np.ndarray:
    """(H, W): the tonemapped image's mean over R, G, B."""
    return tonemap(image).mean(axis=-1)
