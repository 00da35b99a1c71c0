"""The sparse frame: what one masked render hands to the completion stages."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import GmcptError

#: Primary rays per pixel of the feature pass. The traced radiance is an antialiased mean of 16 or so
#: samples; a 1-sample albedo is aliased at texture and silhouette edges, and demodulating one by the
#: other leaves that aliasing in every filled pixel; OIDN, the last stage, reads the same buffers as guides.
#: Measured with the budget default at 4.8 samples a pixel (256x256, 3 seeds, docs/experiments.md): 4 -> 16
#: gains 0.0-0.9 dB a scene (sponza +0.5, still life +0.9) for 0.05 s at 256x256 and 1 s at 1920x1080.
DEFAULT_FEATURE_SPP = 16

#: The per-pixel buffers of a :class:`SparseFrame` and their channels (None: an (H, W) plane).
PIXEL_BUFFERS = {"radiance": 3, "mask": None, "variance": None, "albedo": 3, "normal": 3, "depth": None,
                 "visibility": None, "coverage": None}


@dataclass(frozen=True)
class SparseFrame:
    """A sparsely path-traced image and its dense feature buffers.

    All arrays are float32 (``mask`` is bool), row-major ``(H, W, ...)``.

    Attributes
    ----------
    radiance : (H, W, 3) linear RGB, the box estimate of each traced pixel, 0 elsewhere.
    mask : (H, W) bool, True where the pixel was path traced.
    variance : (H, W) variance of the traced pixel mean (average over RGB), 0 elsewhere.
    albedo : (H, W, 3) diffuse reflectance at the first hit, in [0, 1] (0 for misses and for BSDFs without
        a diffuse lobe: glass, metal).
    normal : (H, W, 3) world-space shading normal at the first hit (0 for misses).
    depth : (H, W) hit distance divided by the largest in the image; misses are 1.
    visibility : (H, W) fraction of shadow rays from the first hit that reach a light.
    spp : samples per traced pixel.
    info : free-form metadata (mask pattern, seed, counts of dropped samples, ...).
    coverage : (H, W) fraction of the feature rays that hit a surface with a diffuse albedo (see
        :mod:`gmcpt.image.domain`), or None where it was not recorded.
    """

    radiance: np.ndarray
    mask: np.ndarray
    variance: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    depth: np.ndarray
    visibility: np.ndarray
    spp: int = 1
    info: dict = field(default_factory=dict)
    coverage: np.ndarray | None = None

    def __post_init__(self):
        h, w = self.mask.shape
        for name, channels in PIXEL_BUFFERS.items():
            shape = (h, w) if channels is None else (h, w, channels)
            array = getattr(self, name)
            if array is not None and array.shape != shape:
                raise GmcptError(f"SparseFrame.{name} has shape {array.shape}, expected {shape}")
        if self.mask.dtype != bool:
            raise GmcptError("SparseFrame.mask must be a boolean array")

    @property
    def shape(self) -> tuple[int, int]:
        return self.mask.shape

    @property
    def rendered_fraction(self) -> float:
        return float(self.mask.mean())

    def features(self) -> np.ndarray:
        """(H, W, 8) stack of albedo, normal, depth, visibility."""
        return np.concatenate([self.albedo, self.normal, self.depth[..., None],
                               self.visibility[..., None]], axis=-1)
