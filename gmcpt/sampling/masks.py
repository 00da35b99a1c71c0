"""Sampling masks: which pixels get path traced.

Every pattern selects exactly ``round(rate * H * W)`` pixels (at least one), is
a pure function of its arguments, and is reproducible from ``seed``.

- ``random``: uniform without replacement, as in the paper.
- ``stratified``: pixels are ordered along a Morton (Z-order) curve, the curve is
  cut into ``n`` equal strata and one jittered pixel is picked in each; this
  spreads samples evenly without the clumps and holes of white noise.
- ``blue_noise``: white noise high-pass filtered in the Fourier domain (a
  Gaussian low-pass subtracted), then the ``n`` largest values are kept. Cheap,
  exact in count, and free of low-frequency clumping.
- ``adaptive``: a pixel's chance follows a sampling density (mean 1) from the
  feature buffers (:func:`gmcpt.sampling.placement.feature_density`); the ``n`` pixels
  with the largest ``density / threshold`` are kept, the threshold a
  blue-noise map with uniform values, so the picks are spread like
  ``blue_noise`` where the density is even (ordered dithering).
- ``two_pass``: ``adaptive`` for part of the budget, then the rest where the
  first pass's samples say completion will err, on the same thresholds
  (:func:`gmcpt.sampling.strategies.render_sparse_frame` runs both passes).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from ..errors import GmcptError
from ..seeds import MASK_STREAM, THRESHOLD_MAP_SEED

PATTERNS = ("random", "stratified", "blue_noise", "adaptive", "two_pass")
#: the placement of the CLI, the scene XML and the Python API when none is named
DEFAULT_PATTERN = "two_pass"
#: the fraction of pixels traced when a rate is wanted and none is named; with no spp either, the scene XML
#: and the CLI trace a budget of DEFAULT_RATE x the sampler's spp instead (mitsuba_plugins/masked_path.py)
DEFAULT_RATE = 0.3
#: patterns that need the feature buffers (they are drawn after the feature pass)
FEATURE_PATTERNS = ("adaptive", "two_pass")


def check_rate(rate: float) -> float:
    """Validate a sampling rate: a finite number in (0, 1]."""
    try:
        rate = float(rate)
    except (TypeError, ValueError):
        raise GmcptError(f"rate must be a number in (0, 1], got {rate!r}") from None
    if not math.isfinite(rate) or not 0.0 < rate <= 1.0:
        raise GmcptError(f"rate must be in (0, 1], got {rate}")
    return rate


def sample_count(rate: float, n_pixels: int) -> int:
    return max(1, min(n_pixels, int(round(rate * n_pixels))))


def check_pattern(pattern: str) -> str:
    if pattern not in PATTERNS:
        raise GmcptError(f"unknown mask pattern {pattern!r}; choose from {', '.join(PATTERNS)}")
    return pattern


def mask_rng(seed: int) -> np.random.Generator:
    """The random generator of a density-driven mask; both passes of ``two_pass`` draw with it (the same
    threshold map). The seed sequence's trailing 0 keeps the first passes of earlier versions."""
    return np.random.default_rng([int(seed), MASK_STREAM, 0])


def make_mask(height: int, width: int, rate: float, pattern: str = "random",
              seed: int = 0, density: np.ndarray | None = None) -> np.ndarray:
    """Return an (H, W) boolean mask with ``round(rate*H*W)`` True pixels.

    Parameters
    ----------
    height, width : image size in pixels.
    rate : fraction of pixels to trace, in (0, 1].
    pattern : one of ``PATTERNS``; ``two_pass`` gives its first pass (``adaptive``) here.
    seed : seed of the pattern's random generator.
    density : (H, W) sampling density of ``adaptive`` / ``two_pass``
        (:func:`gmcpt.sampling.placement.feature_density`).
    """
    rate = check_rate(rate)
    check_pattern(pattern)
    n_pixels = height * width
    count = sample_count(rate, n_pixels)
    rng = np.random.default_rng([int(seed), MASK_STREAM])
    if pattern in FEATURE_PATTERNS:
        if density is None or density.shape != (height, width):
            raise GmcptError(f"the {pattern!r} mask needs an ({height}, {width}) sampling density")
        return sample_by_density(density, count, mask_rng(seed))
    if count == n_pixels:
        chosen = np.arange(n_pixels)
    elif pattern == "random":
        chosen = rng.choice(n_pixels, size=count, replace=False)
    elif pattern == "stratified":
        chosen = _stratified(height, width, count, rng)
    else:
        chosen = _blue_noise(height, width, count, rng)
    mask = np.zeros(n_pixels, dtype=bool)
    mask[chosen] = True
    return mask.reshape(height, width)


def _morton_order(height: int, width: int) -> np.ndarray:
    """Flat pixel indices sorted along a Z-order curve."""
    y, x = np.mgrid[0:height, 0:width]
    code = np.zeros((height, width), dtype=np.uint64)
    for bit in range(16):
        code |= ((x.astype(np.uint64) >> bit) & 1) << np.uint64(2 * bit)
        code |= ((y.astype(np.uint64) >> bit) & 1) << np.uint64(2 * bit + 1)
    return np.argsort(code.ravel(), kind="stable")


def _stratified(height: int, width: int, count: int, rng: np.random.Generator) -> np.ndarray:
    order = _morton_order(height, width)
    edges = np.linspace(0, order.size, count + 1)
    starts = np.ceil(edges[:-1]).astype(np.int64)
    ends = np.maximum(np.ceil(edges[1:]).astype(np.int64), starts + 1)
    picks = starts + np.floor(rng.random(count) * (ends - starts)).astype(np.int64)
    return order[np.minimum(picks, order.size - 1)]


def _highpassed_noise(height: int, width: int, rng: np.random.Generator, rate: float) -> np.ndarray:
    """White noise less its Gaussian low-pass (radius about half the mean spacing of picks at ``rate``)."""
    noise = rng.standard_normal((height, width))
    sigma = 0.5 / math.sqrt(rate)
    fy = np.fft.fftfreq(height)[:, None]
    fx = np.fft.rfftfreq(width)[None, :]
    lowpass = np.exp(-2.0 * (math.pi * sigma) ** 2 * (fx ** 2 + fy ** 2))
    return np.fft.irfft2(np.fft.rfft2(noise) * (1.0 - lowpass), s=(height, width))


def _blue_noise(height: int, width: int, count: int, rng: np.random.Generator) -> np.ndarray:
    highpassed = _highpassed_noise(height, width, rng, count / (height * width))
    return np.argpartition(-highpassed.ravel(), count - 1)[:count]


#: side of the blue-noise threshold tile that the density-driven masks repeat over the frame
THRESHOLD_TILE = 128


@functools.lru_cache(maxsize=1)
def _threshold_tile() -> np.ndarray:
    """(T, T) thresholds in (0, 1), uniformly distributed, blue-noise arranged (made once per process)."""
    highpassed = _highpassed_noise(THRESHOLD_TILE, THRESHOLD_TILE, np.random.default_rng(THRESHOLD_MAP_SEED), 0.25)
    ranks = np.empty(highpassed.size, np.float64)
    ranks[np.argsort(highpassed.ravel(), kind="stable")] = np.arange(highpassed.size)
    return ((ranks + 0.5) / ranks.size).reshape(highpassed.shape).astype(np.float32)


def _thresholds(height: int, width: int, rng: np.random.Generator) -> np.ndarray:
    """(H, W) blue-noise thresholds: the tile, flipped, transposed and shifted as ``rng`` says, repeated.
    Read-only: the last placement's map is kept (:func:`_placed_tiles`)."""
    flips = tuple(bool(flip) for flip in rng.integers(0, 2, size=3))
    dy, dx = (int(shift) for shift in rng.integers(0, THRESHOLD_TILE, size=2))
    return _placed_tiles(height, width, flips, dy, dx)


@functools.lru_cache(maxsize=1)
def _placed_tiles(height: int, width: int, flips: tuple[bool, bool, bool], dy: int, dx: int) -> np.ndarray:
    """The threshold map of :func:`_thresholds`, kept until a placement of another size or seed: both
    passes of a ``two_pass`` frame draw on the same map, and so do frames rendered with the same seed.
    One map only: a 3840x2160 one is 33 MB."""
    tile = _threshold_tile()
    if flips[0]:
        tile = tile[::-1]
    if flips[1]:
        tile = tile[:, ::-1]
    if flips[2]:
        tile = tile.T
    shifted = np.roll(tile, (-dy, -dx), axis=(0, 1))  # element (y, x) is the tile's (y + dy, x + dx)
    repeats = (-(-height // THRESHOLD_TILE), -(-width // THRESHOLD_TILE))
    thresholds = np.ascontiguousarray(np.tile(shifted, repeats)[:height, :width])
    thresholds.setflags(write=False)
    return thresholds


#: every SELECTION_STRIDE-th key is sorted to bracket the k-th smallest; the bracket spans
#: SELECTION_SPREAD standard deviations of the sample's rank on either side (a miss falls back, same result)
SELECTION_STRIDE = 16
SELECTION_SPREAD = 4.0


def _kth_smallest(keys: np.ndarray, k: int) -> np.float32:
    """``np.partition(keys, k)[k]`` of a flat array, in a third of its time at 256x256: a sorted sample of
    the keys brackets the value, and only the keys inside the bracket are partitioned."""
    sample = np.sort(keys[::SELECTION_STRIDE])
    centre = (k + 0.5) * sample.size / keys.size
    margin = SELECTION_SPREAD * math.sqrt(max(centre * (1.0 - centre / sample.size), 1.0)) + 2.0
    low, high = int(centre - margin), int(centre + margin)
    if low >= 0 and high < sample.size:
        below = int(np.count_nonzero(keys < sample[low]))
        inside = keys[(keys >= sample[low]) & (keys <= sample[high])]
        if below <= k < below + inside.size:
            return np.partition(inside, k - below)[k - below]
    return np.partition(keys, k)[k]


def second_pass_mask(errors: np.ndarray, count: int, first: np.ndarray, seed: int) -> np.ndarray:
    """The second pass of ``two_pass``: ``count`` pixels by the density ``errors``, none of the first pass's
    ``first``, on the first pass's threshold map (:func:`mask_rng` of the same ``seed``), so where both
    densities are even the two passes together are one blue-noise set at the whole rate."""
    return sample_by_density(errors, count, mask_rng(seed), exclude=first)


def sample_by_density(density: np.ndarray, count: int, rng: np.random.Generator,
                      exclude: np.ndarray | None = None) -> np.ndarray:
    """(H, W) bool mask of exactly ``count`` pixels drawn with chances that follow ``density``.

    The ``count`` largest ``density / threshold`` win, the thresholds a uniform blue-noise map
    (a 128 x 128 tile, placed at random):
    a pixel of density d is picked about when its threshold is below ``d / theta`` (theta the
    ``count``-th largest key), so its chance grows with d and is spread evenly in space.
    ``exclude`` (bool) pixels are never picked; ``count`` is clipped to the pixels left.
    """
    height, width = density.shape
    available = height * width - (0 if exclude is None else int(np.count_nonzero(exclude)))
    count = int(min(count, available))
    mask = np.zeros(height * width, bool)
    if count <= 0:
        return mask.reshape(height, width)
    # keys = -(max(density, 0) + 1e-12) / thresholds, in one float32 buffer (NaN and inf count as 0)
    keys = np.maximum(density, np.float32(0.0), dtype=np.float32)
    if not np.isfinite(keys).all():
        np.nan_to_num(keys, copy=False, nan=0.0, posinf=0.0)
    keys += np.float32(1e-12)
    keys /= _thresholds(height, width, rng)
    np.negative(keys, out=keys)
    if exclude is not None:
        keys[exclude] = np.float32(1.0)  # after every allowed key, which are all negative
    # the count smallest keys: those below the count-th, then as many equal to it as are missing, in
    # pixel order (a bracketed partition of the values and two comparisons)
    keys = keys.ravel()
    kth = _kth_smallest(keys, count - 1)
    np.less(keys, kth, out=mask)
    ties = np.flatnonzero(keys == kth)
    mask[ties[:count - int(np.count_nonzero(mask))]] = True
    return mask.reshape(height, width)
