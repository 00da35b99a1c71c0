"""Intel Open Image Denoise (``pyoidn``, CPU, weights inside its wheel): the last stage of the ``*_oidn``
methods (:mod:`gmcpt.completion.denoised`) and the path tracing + OIDN baseline."""
from __future__ import annotations

import sys
import threading

import numpy as np

from ..errors import GmcptError


#: Guides averaged over this many primary rays a pixel or more are as good as noise-free to OIDN. Taken so
#: (``clean_aux``), OIDN runs its large model, 2.3x the time (0.13 s against 0.055 at 256x256): over a frame of
#: 16 samples a pixel with 16-ray guides that gains 0.12-0.56 dB on all nine evaluation scenes, more than the
#: time would buy in samples; at 4-8 samples it does not pay (docs/experiments.md).
CLEAN_GUIDE_RAYS = 16


def takes_clean_guides(guide_rays: int) -> bool:
    """Whether OIDN takes guides of ``guide_rays`` primary rays a pixel as noise-free (:data:`CLEAN_GUIDE_RAYS`)."""
    return guide_rays >= CLEAN_GUIDE_RAYS


def denoise_oidn(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray, guide_rays: int = 0) -> np.ndarray:
    """(H, W, 3) float32: OIDN's HDR filter on linear radiance ``image``, with albedo and normal as guides.
    ``guide_rays``: the primary rays a pixel the guides are the mean of (0: not known); from
    :data:`CLEAN_GUIDE_RAYS` OIDN takes them as noise-free (:func:`takes_clean_guides`)."""
    pyoidn = _pyoidn()
    contiguous = lambda array: np.ascontiguousarray(array, dtype=np.float32)  # noqa: E731
    return np.asarray(pyoidn.denoise(contiguous(image), contiguous(albedo), contiguous(normal), hdr=True,
                                    clean_aux=takes_clean_guides(guide_rays)),
                      dtype=np.float32)


_IMPORTING = threading.Lock()


def _pyoidn():
    """``pyoidn``, imported without torch where torch is not loaded yet: pyoidn imports it, if it can, for tensor
    inputs that gmcpt never passes, and that import took 5-6 s of the first dense frame in a process (a 10-s time
    budget spent 16 s from the command line)."""
    with _IMPORTING:
        hide_torch = "pyoidn" not in sys.modules and "torch" not in sys.modules
        if hide_torch:
            sys.modules["torch"] = None  # ``import torch`` raises ImportError: pyoidn takes it as no torch
        try:
            import pyoidn
        except ImportError:
            raise GmcptError("Intel Open Image Denoise is missing: pip install pyoidn (a gmcpt dependency)") from None
        finally:
            if hide_torch:
                del sys.modules["torch"]
    return pyoidn
