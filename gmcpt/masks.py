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
"""
from __future__ import annotations

import math

import numpy as np

from .errors import GmcptError

PATTERNS = ("random", "stratified", "blue_noise")


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


def make_mask(height: int, width: int, rate: float, pattern: str = "random",
              seed: int = 0) -> np.ndarray:
    """Return an (H, W) boolean mask with ``round(rate*H*W)`` True pixels.

    Parameters
    ----------
    height, width : image size in pixels.
    rate : fraction of pixels to trace, in (0, 1].
    pattern : one of ``PATTERNS``.
    seed : seed of the pattern's random generator.
    """
    rate = check_rate(rate)
    if pattern not in PATTERNS:
        raise GmcptError(f"unknown mask pattern {pattern!r}; choose from {', '.join(PATTERNS)}")
    n_pixels = height * width
    count = sample_count(rate, n_pixels)
    rng = np.random.default_rng([int(seed), 0x6D61736B])  # 'mask'
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


def _blue_noise(height: int, width: int, count: int, rng: np.random.Generator) -> np.ndarray:
    noise = rng.standard_normal((height, width))
    rate = count / (height * width)
    sigma = 0.5 / math.sqrt(rate)  # low-pass radius ~ half the mean sample spacing
    fy = np.fft.fftfreq(height)[:, None]
    fx = np.fft.rfftfreq(width)[None, :]
    lowpass = np.exp(-2.0 * (math.pi * sigma) ** 2 * (fx ** 2 + fy ** 2))
    highpassed = np.fft.irfft2(np.fft.rfft2(noise) * (1.0 - lowpass), s=(height, width))
    return np.argpartition(-highpassed.ravel(), count - 1)[:count]
