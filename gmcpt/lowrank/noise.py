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
    box = lambda image: uniform_filter(image, size=(size, size, 1), mode="reflect") * size * size  # noqa: E731
    count = box(weight[..., None])[..., 0]
    masked = values * weight[..., None]
    total, squares = box(masked), box(masked ** 2)
    enough = count > 1.5
    n = np.maximum(count, 2.0)[..., None]
    variance = np.maximum(squares - total ** 2 / n, 0.0) / (n - 1)
    return np.where(enough, variance.mean(-1), 0.0).astype(np.float32)


def working_variance(frame, domain, observed: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """(H, W) variance of a frame's rendered pixel means in ``domain``: the renderer's where it has one
    (2 or more samples per pixel), :func:`local_variance` of ``observed`` at one sample per pixel."""
    if frame.spp > 1:
        return domain.variance(frame.radiance, frame.variance, factor)
    return local_variance(observed, frame.mask)


def blend_samples(estimate: np.ndarray, observed: np.ndarray, mask: np.ndarray, variance: np.ndarray,
                  radius: int = 6, floor: float = 1e-2) -> np.ndarray:
    """Put the rendered samples back into an estimate, each as far as its noise allows.

    At rendered pixels returns ``estimate + delta * (observed - estimate)`` with
    the Wiener factor ``delta = tau2 / (tau2 + variance)``, where ``tau2``, the
    error variance of the estimate, is measured locally: the mean over the
    rendered pixels of the window of ``(observed - estimate)^2 - variance``
    (at least ``floor``). Where the estimate is good the noisy samples are
    mostly ignored; where it is off they pull it back. Other pixels are unchanged.

    Parameters
    ----------
    estimate, observed : (H, W, C) images (``observed`` valid where ``mask``).
    mask : (H, W) bool.
    variance : (H, W) variance of each rendered value.
    radius : the window is ``2 * radius + 1`` pixels a side.
    floor : smallest ``tau2``.
    """
    estimate = np.asarray(estimate, np.float32)
    if estimate.shape != np.shape(observed) or not estimate.shape[:2] == np.shape(mask) == np.shape(variance):
        raise ValueError("estimate, observed, mask and variance must share H and W")
    size = 2 * radius + 1
    weight = np.asarray(mask, np.float32)
    residual = np.where(mask, np.mean((observed - estimate) ** 2, axis=-1) - variance, 0.0)
    tau2 = uniform_filter(residual.astype(np.float32), size, mode="reflect") \
        / np.maximum(uniform_filter(weight, size, mode="reflect"), 1e-6)
    tau2 = np.maximum(tau2, floor)
    delta = np.where(mask, tau2 / (tau2 + variance), 0.0)[..., None]
    return (estimate + delta * (np.where(mask[..., None], observed, estimate) - estimate)).astype(np.float32)
