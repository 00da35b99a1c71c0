"""The working domain of the completion stages (METHOD.md section 2).

Radiance is *demodulated* (divided by albedo where the surface has a
meaningful diffuse albedo, so textures drop out and come back exactly at the
end) and *compressed* with ``log1p`` scaled to an 8-bit-like range, so that
fireflies do not dominate distances and singular-value thresholds behave as
on an 8-bit photograph (the scale the paper's w0 = 80.5 was set on).

``y = SCALE * log1p(x / factor)`` with ``factor = albedo + eps`` where
``max(albedo) >= ALBEDO_MIN`` and 1 elsewhere (glass, emitters, background).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WorkingDomain:
    """Parameters of the forward/inverse transform.

    Attributes
    ----------
    albedo_min : below this (largest channel) albedo, a pixel is not demodulated.
    albedo_eps : added to albedo before dividing, to tame dark textures.
    scale : multiplier after ``log1p``; 92 maps demodulated radiance 0..15 to 0..255.
    """

    albedo_min: float = 0.02
    albedo_eps: float = 0.02
    scale: float = 92.0

    def factor(self, albedo: np.ndarray) -> np.ndarray:
        """(H, W, 3) demodulation factor from an (H, W, 3) albedo buffer."""
        meaningful = albedo.max(axis=-1, keepdims=True) >= self.albedo_min
        return np.where(meaningful, albedo + self.albedo_eps, 1.0).astype(np.float32)

    def forward(self, radiance: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """Linear HDR radiance -> working domain."""
        return (self.scale * np.log1p(np.maximum(radiance, 0.0) / factor)).astype(np.float32)

    def inverse(self, working: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """Working domain -> linear HDR radiance."""
        return (np.expm1(np.maximum(working, 0.0) / self.scale) * factor).astype(np.float32)

    def encode(self, frame) -> tuple[np.ndarray, np.ndarray]:
        """A SparseFrame's samples in the working domain: ``(working, factor)``."""
        factor = self.factor(frame.albedo)
        return self.forward(frame.radiance, factor), factor

    def variance(self, radiance: np.ndarray, variance: np.ndarray, factor: np.ndarray) -> np.ndarray:
        """First-order (delta method) variance in the working domain, (H, W)."""
        slope = self.scale / (factor + np.maximum(radiance, 0.0))  # dy/dx, (H, W, 3)
        return (variance * np.mean(slope ** 2, axis=-1)).astype(np.float32)
