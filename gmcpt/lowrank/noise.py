"""Noise level of rendered pixels, as the soft data terms (PAWNNM's, :func:`blend_samples`) use it.

With one sample per pixel the sample variance is undefined and the frame
carries 0, which would make the soft data term of PAWNNM keep the raw samples
(their Wiener factor is 1). :func:`local_variance` gives a stand-in: the
variance of the rendered values in a small window around each rendered pixel.
In flat regions that is the noise variance; across edges it overestimates it,
which only leans those pixels further towards the low-rank estimate.

With several samples the renderer's variance is used, shrunk towards that of
the neighbours (:func:`shrunk_variance`): a few samples of heavy-tailed
radiance mostly miss the rare bright paths, so a pixel's own estimate is
often far too small, down to 0 when every sample found no light.
"""
from __future__ import annotations

import numpy as np

from ..image.domain import channel_mean


def _box_mean(image: np.ndarray, size, mode: str) -> np.ndarray:
    """scipy's box mean, imported on first use: ``scipy.ndimage`` costs every process 1.3 s at start, a command's
    refusal of bad input included."""
    from scipy.ndimage import uniform_filter

    return uniform_filter(image, size=size, mode=mode)


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
    box = lambda image: _box_mean(image, size=(size, size, 1), mode="reflect") * size * size  # noqa: E731
    count = box(weight[..., None])[..., 0]
    masked = values * weight[..., None]
    total, squares = box(masked), box(masked ** 2)
    enough = count > 1.5
    n = np.maximum(count, 2.0)[..., None]
    variance = np.maximum(squares - total ** 2 / n, 0.0) / (n - 1)
    return np.where(enough, channel_mean(variance), 0.0).astype(np.float32)


#: Weight of the neighbours in :func:`shrunk_variance`, which :func:`working_variance` applies in the
#: working domain. Measured with the 300-scene gan-cpu weights (mean PSNR dB; validation split, then
#: the 5 evaluation scenes at rates 0.2/0.3/0.4), own variance alone against weight 0.5: ``pawnnm``
#: 29.39 -> 29.61, 32.58/33.19/33.73 -> 32.65/33.30/33.93; ``gan`` 29.88 -> 30.64, 32.85/33.18/33.43 ->
#: 32.92/33.28/33.58; ``gan_pawnnm`` 30.33 -> 31.30, 33.75/34.21/34.51 -> 33.80/34.30/34.67. The gain is
#: on the noisiest scenes (validation scene 1000007; the breakfast room, ``pawnnm`` +0.35/+0.61/+0.92)
#: and about 0 elsewhere. Shrinking the linear variance instead, weights 0.3 and 0.7 scored within
#: 0.03 dB of 0.5, but the emitter's huge variance spread to its neighbours (the Cornell box's traced
#: pixels came out 10% brighter than their samples at 64 px, 4 spp); taking the larger of own and
#: neighbours' variance cost the Cornell box 0.2-0.3 dB (true black background beside lit pixels).
VARIANCE_SHRINKAGE = 0.5


def shrunk_variance(variance: np.ndarray, mask: np.ndarray, weight: float = VARIANCE_SHRINKAGE,
                    radius: int = 3) -> np.ndarray:
    """Each rendered pixel's variance pulled towards the mean variance of the rendered pixels near it.

    Parameters
    ----------
    variance : (H, W) variance of each rendered pixel's mean (valid where ``mask``).
    mask : (H, W) bool, the rendered pixels.
    weight : share of the neighbourhood mean, in [0, 1] (0 keeps ``variance``).
    radius : the window is ``2 * radius + 1`` pixels a side.

    Returns
    -------
    (H, W) float32 ``(1 - weight) * variance + weight * mean``, 0 where not rendered.
    """
    if not 0.0 <= weight <= 1.0:
        raise ValueError(f"weight must be in [0, 1], got {weight}")
    mask = np.asarray(mask, bool)
    nearby = _masked_mean(np.asarray(variance, np.float64)[..., None], mask, radius)[..., 0]
    shrunk = (1.0 - weight) * variance + weight * nearby
    return np.where(mask, np.maximum(shrunk, 0.0), 0.0).astype(np.float32)


def local_noise_scale(variance: np.ndarray, mask: np.ndarray, radius: int = 5, power: float = 0.5) -> np.ndarray:
    """(H, W) relative noise level: the mean variance of the rendered pixels around each pixel, divided
    by that map's frame mean, to the ``power`` (all ones where the frame has no variance)."""
    nearby = _masked_mean(np.asarray(variance, np.float64)[..., None], np.asarray(mask, bool), radius)[..., 0]
    mean = float(nearby.mean())
    if not mean > 0:
        return np.ones(nearby.shape, np.float32)
    return ((np.maximum(nearby, 1e-6 * mean) / mean) ** power).astype(np.float32)


def _masked_mean(values: np.ndarray, mask: np.ndarray, radius: int) -> np.ndarray:
    """(H, W, C) mean of ``values`` over the pixels of ``mask`` in each window (0 where it has none)."""
    size = 2 * radius + 1
    weight = np.asarray(mask, np.float64)
    count = _box_mean(weight, size=size, mode="reflect")
    total = _box_mean(values * weight[..., None], size=(size, size, 1), mode="reflect")
    return np.where(count[..., None] > 1e-9, total / np.maximum(count, 1e-12)[..., None], 0.0)


def working_variance(frame, domain, observed: np.ndarray, factor: np.ndarray) -> np.ndarray:
    """(H, W) variance of a frame's rendered pixel means in ``domain``: the renderer's where it has one
    (2 or more samples per pixel), shrunk towards the neighbours' (:func:`shrunk_variance`);
    :func:`local_variance` of ``observed`` at one sample per pixel."""
    if frame.spp > 1:
        return shrunk_variance(domain.variance(frame.radiance, frame.variance, factor), frame.mask)
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
    difference = observed - estimate
    residual = np.where(mask, channel_mean(difference * difference) - variance, 0.0)
    tau2 = _box_mean(residual.astype(np.float32), size, mode="reflect") \
        / np.maximum(_box_mean(weight, size, mode="reflect"), 1e-6)
    tau2 = np.maximum(tau2, floor)
    delta = np.where(mask, tau2 / (tau2 + variance), 0.0)[..., None]
    return (estimate + delta * (np.where(mask[..., None], observed, estimate) - estimate)).astype(np.float32)
