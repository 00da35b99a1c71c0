"""The working domain of the completion stages (docs/design.md section 2).

Radiance is *demodulated* (divided by albedo where the surface has a
meaningful diffuse albedo, so textures drop out and come back exactly at the
end) and *compressed* with ``log1p`` scaled to an 8-bit-like range, so that
fireflies do not dominate distances and singular-value thresholds behave as
on an 8-bit photograph (the scale the paper's w0 = 80.5 was set on).

``y = SCALE * log1p(x / factor)``. Each feature ray has a factor of its own:
``albedo + eps`` where it hits a surface with a diffuse albedo of at least
:data:`ALBEDO_MIN`, 1 elsewhere (glass, metal, emitters, background); a pixel's
factor is the mean over its rays, ``albedo + coverage * eps + (1 - coverage)``
with ``coverage`` the fraction of rays of the first kind (the feature pass
records it). Without a coverage buffer a pixel is either demodulated
(``max(albedo) >= ALBEDO_MIN``) or not, and a silhouette pixel against the sky,
whose albedo is a small mean of a few surface rays and many misses, gets a
tiny factor for radiance that is mostly sky's: measured on the held-out
procedural scene ``proc-2000000`` at rate 0.2, the horizon alone then held 65%
of ``gan``'s squared error.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Diffuse albedo (largest channel) below which a ray's radiance is not divided by it.
ALBEDO_MIN = 0.02


def channel_mean(image: np.ndarray) -> np.ndarray:
    """Mean over the last axis of a (..., C) array, as a sum of channel planes: numpy's reduction over a
    short last axis is ten times slower (1024x1024x3: 23 ms against 2.3 ms)."""
    total = image[..., 0].astype(np.result_type(image.dtype, np.float32), copy=True)
    for channel in range(1, image.shape[-1]):
        total += image[..., channel]
    total *= 1.0 / image.shape[-1]
    return total


def pixel_coverage(albedo: np.ndarray, albedo_min: float = ALBEDO_MIN) -> np.ndarray:
    """(H, W) float32 coverage of a frame that has none recorded: 1 where the pixel's albedo is
    meaningful (``max(albedo) >= albedo_min``), 0 elsewhere."""
    return (albedo.max(axis=-1) >= albedo_min).astype(np.float32)


def frame_coverage(frame) -> np.ndarray:
    """(H, W) float32 coverage of a :class:`~gmcpt.frame.SparseFrame`: its own buffer, or the 0/1 rule
    (:func:`pixel_coverage`) that :meth:`WorkingDomain.factor` assumes for frames without one."""
    return pixel_coverage(frame.albedo) if frame.coverage is None else frame.coverage.astype(np.float32)


@dataclass(frozen=True)
class WorkingDomain:
    """Parameters of the forward/inverse transform.

    Attributes
    ----------
    albedo_min : below this (largest channel) albedo, a pixel is not demodulated.
    albedo_eps : added to albedo before dividing, to tame dark textures.
    scale : multiplier after ``log1p``; 92 maps demodulated radiance 0..15 to 0..255.
    """

    albedo_min: float = ALBEDO_MIN
    albedo_eps: float = 0.02
    scale: float = 92.0

    def factor(self, albedo: np.ndarray, coverage: np.ndarray | None = None) -> np.ndarray:
        """(H, W, 3) demodulation factor from an (H, W, 3) albedo buffer and, if there is one, the
        (H, W) fraction of each pixel's feature rays that hit a diffuse surface (``coverage``)."""
        if coverage is None:
            meaningful = pixel_coverage(albedo, self.albedo_min)[..., None] > 0
            return np.where(meaningful, albedo + self.albedo_eps, 1.0).astype(np.float32)
        covered = np.clip(coverage, 0.0, 1.0)[..., None]
        return (albedo + covered * self.albedo_eps + (1.0 - covered)).astype(np.float32)

    def frame_factor(self, frame) -> np.ndarray:
        """The demodulation factor of a :class:`~gmcpt.frame.SparseFrame`."""
        return self.factor(frame.albedo, frame.coverage)

    def forward(self, radiance: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """Linear HDR radiance -> working domain."""
        return (self.scale * np.log1p(np.maximum(radiance, 0.0) / factor)).astype(np.float32)

    def inverse(self, working: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """Working domain -> linear HDR radiance."""
        return (np.expm1(np.maximum(working, 0.0) / self.scale) * factor).astype(np.float32)

    def forward_traced(self, radiance: np.ndarray, factor: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """:meth:`forward` of the (H, W) ``mask``'s pixels of (H, W, C) ``radiance``, 0 elsewhere (at 30% of
        the pixels, 27 ms instead of 47 for a 1024x1024 frame)."""
        pixels = np.flatnonzero(mask)
        channels = radiance.shape[-1]
        working = np.zeros(radiance.shape, np.float32)
        working.reshape(-1, channels)[pixels] = self.forward(radiance.reshape(-1, channels)[pixels],
                                                             factor.reshape(-1, channels)[pixels])
        return working

    def encode(self, frame) -> tuple[np.ndarray, np.ndarray]:
        """A SparseFrame's samples in the working domain, 0 at untraced pixels: ``(working, factor)``."""
        factor = self.frame_factor(frame)
        return self.forward_traced(frame.radiance, factor, frame.mask), factor

    def variance(self, radiance: np.ndarray, variance: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """First-order (delta method) variance in the working domain, (H, W)."""
        slope = self.scale / (factor + np.maximum(radiance, 0.0))  # dy/dx, (H, W, 3)
        return (variance * channel_mean(slope * slope)).astype(np.float32)
