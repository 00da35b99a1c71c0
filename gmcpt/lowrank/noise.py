"""Noise level of rendered pixels when the renderer could not measure it (one sample per pixel).

With one sample per pixel the sample variance is undefined and the frame
carries 0, which would make the soft data term of PAWNNM keep the raw samples
(their Wiener factor is 1). :func:`local_variance` gives a stand-in: the
variance of the rendered values in a small window around each rendered pixel.
In flat regions that is the noise variance; across edges it overestimates it,
which only leans those pixels further towards the low-rank estimate.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter


def local_variance(values: np.ndarray, mask: np.ndarray, radius: int = 3) -> np.ndarray:
    """Channel-averaged variance of the rendered values in a window around each pixel.

    Parameters
    ----------
    values : (H, W, C) image, valid where ``mask``.
    mask : (H, W) bool, the rendered pixels.
    radius : the window is ``2 * radius + 1`` pixels a side.

    Returns
    -------
    (H, W) float32 unbiased variance of the rendered values in each window (0
    where the window holds fewer than two rendered pixels).
    """
    values = np.asarray(values, np.float64)
    if values.ndim != 3 or values.shape[:2] != np.shape(mask):
        raise ValueError(f"values must be (H, W, C) matching mask {np.shape(mask)}, got {values.shape}")
    if radius < 1:
        raise ValueError(f"radius must be >= 1, got {radius}")
    size = 2 * radius + 1
    weight = np.asarray(mask, np.float64)
    box = lambda image: uniform_filter(image, size=size, mode="reflect") * size * size  # noqa: E731
    count = box(weight)
    masked = values * weight[..., None]
    total = np.stack([box(masked[..., c]) for c in range(values.shape[-1])], -1)
    squares = np.stack([box(masked[..., c] ** 2) for c in range(values.shape[-1])], -1)
    enough = count > 1.5
    n = np.maximum(count, 2.0)[..., None]
    variance = np.maximum(squares - total ** 2 / n, 0.0) / (n - 1)
    return np.where(enough, variance.mean(-1), 0.0).astype(np.float32)
