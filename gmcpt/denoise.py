"""Intel Open Image Denoise (``pyoidn``, CPU, weights inside its wheel): the last stage of the ``*_oidn``
methods (:mod:`gmcpt.completion.denoised`) and the path tracing + OIDN baseline."""
from __future__ import annotations

import numpy as np

from .errors import GmcptError


def denoise_oidn(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: OIDN's HDR filter on linear radiance ``image``, with albedo and normal as guides."""
    try:
        import pyoidn
    except ImportError:
        raise GmcptError("Intel Open Image Denoise is missing: pip install pyoidn (a dependency of gmcpt)") from None
    contiguous = lambda array: np.ascontiguousarray(array, dtype=np.float32)  # noqa: E731
    return np.asarray(pyoidn.denoise(contiguous(image), contiguous(albedo), contiguous(normal), hdr=True),
                      dtype=np.float32)
