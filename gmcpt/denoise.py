"""Intel Open Image Denoise (``pyoidn``, CPU, weights inside its wheel): the path tracing + OIDN baseline.

``pyoidn`` is an optional dependency (``pip install -e '.[dev]'``).
"""
from __future__ import annotations

import numpy as np

from .errors import GmcptError


def denoise_oidn(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: OIDN's HDR filter on linear radiance ``image``, with albedo and normal as guides."""
    try:
        import pyoidn
    except ImportError:
        raise GmcptError("OIDN (the path tracing + OIDN baseline) needs pyoidn: pip install -e '.[dev]'") from None
    contiguous = lambda array: np.ascontiguousarray(array, dtype=np.float32)  # noqa: E731
    return np.asarray(pyoidn.denoise(contiguous(image), contiguous(albedo), contiguous(normal), hdr=True),
                      dtype=np.float32)
