"""Intel Open Image Denoise (``pyoidn``, CPU, weights inside its wheel): the last stage of the ``*_oidn``
methods (:mod:`gmcpt.completion.denoised`) and the path tracing + OIDN baseline."""
from __future__ import annotations

import numpy as np

from .errors import GmcptError


#: Guides averaged over this many primary rays a pixel or more are as good as noise-free to OIDN: taken so
#: (``clean_aux``) over a path traced frame at 4-16 samples a pixel, they gain 0.03-0.84 dB on all nine evaluation
#: scenes (at 1-2 the dining room loses 0.1-0.2); guides of 4 rays lose so on five or six (docs/experiments.md).
CLEAN_GUIDE_RAYS = 16


def denoise_oidn(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray, guide_rays: int = 0) -> np.ndarray:
    """(H, W, 3) float32: OIDN's HDR filter on linear radiance ``image``, with albedo and normal as guides.
    ``guide_rays``: the primary rays a pixel the guides are the mean of (0: not known); from
    :data:`CLEAN_GUIDE_RAYS` OIDN takes them as noise-free."""
    try:
        import pyoidn
    except ImportError:
        raise GmcptError("Intel Open Image Denoise is missing: pip install pyoidn (a dependency of gmcpt)") from None
    contiguous = lambda array: np.ascontiguousarray(array, dtype=np.float32)  # noqa: E731
    return np.asarray(pyoidn.denoise(contiguous(image), contiguous(albedo), contiguous(normal), hdr=True,
                                    clean_aux=guide_rays >= CLEAN_GUIDE_RAYS),
                      dtype=np.float32)
