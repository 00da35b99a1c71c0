"""The layer layout shared by the integrator's output tensor and the EXR file.

Channels, in order (names as tev and Blender group them, ``layer.channel``)::

    R G B                      completed radiance (linear)
    sparse.R sparse.G sparse.B traced radiance, 0 where not traced
    mask.Y                     1 where traced
    albedo.R albedo.G albedo.B
    normal.X normal.Y normal.Z world-space shading normal
    depth.Y                    hit distance / largest in the image (misses: 1)
    visibility.Y               fraction of shadow rays reaching a light
    variance.Y                 variance of each traced pixel's mean
    coverage.Y                 fraction of feature rays on a diffuse surface (see gmcpt.domain)
"""
from __future__ import annotations

import numpy as np

from .domain import frame_coverage
from .frame import SparseFrame

LAYERS = (("", "RGB"), ("sparse", "RGB"), ("mask", "Y"), ("albedo", "RGB"), ("normal", "XYZ"),
          ("depth", "Y"), ("visibility", "Y"), ("variance", "Y"), ("coverage", "Y"))


def channel_names() -> list[str]:
    """Flat list of channel names, in tensor order."""
    return [f"{layer}.{c}" if layer else c for layer, channels in LAYERS for c in channels]


def pack(frame: SparseFrame, image: np.ndarray) -> np.ndarray:
    """Stack the completed image and the frame's buffers into (H, W, 17) float32."""
    parts = [image, np.where(frame.mask[..., None], frame.radiance, 0.0), frame.mask[..., None],
             frame.albedo, frame.normal, frame.depth[..., None], frame.visibility[..., None],
             frame.variance[..., None], frame_coverage(frame)[..., None]]
    return np.concatenate([np.asarray(p, dtype=np.float32) for p in parts], axis=-1)


def unpack(tensor: np.ndarray, spp: int = 1) -> tuple[SparseFrame, np.ndarray]:
    """Inverse of :func:`pack`: ``(frame, completed image)``."""
    array = np.asarray(tensor, dtype=np.float32)
    expected = len(channel_names())
    if array.ndim != 3 or array.shape[-1] != expected:
        raise ValueError(f"expected an (H, W, {expected}) tensor, got shape {array.shape}")
    image, sparse, mask, albedo, normal, depth, visibility, variance, coverage = np.split(
        array, np.cumsum([len(c) for _, c in LAYERS])[:-1], axis=-1)
    frame = SparseFrame(radiance=sparse, mask=mask[..., 0] > 0.5, variance=variance[..., 0], albedo=albedo,
                        normal=normal, depth=depth[..., 0], visibility=visibility[..., 0], spp=spp,
                        coverage=coverage[..., 0])
    return frame, image
