"""Intel Open Image Denoise (``pyoidn``, CPU, weights inside its wheel).

Two users: the path tracing + OIDN baseline of the evaluations, and the GAN's training data, whose
references can be denoised before training (``train.reference_denoiser``; see
:func:`clean_reference`). ``pyoidn`` is an optional dependency (``pip install -e '.[dev]'``).
"""
from __future__ import annotations

import numpy as np

from .errors import GmcptError

#: Values of ``train.reference_denoiser``: none, or OIDN guided by the example's albedo and normal.
REFERENCE_DENOISERS = ("none", "oidn")


def denoise_oidn(image: np.ndarray, albedo: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: OIDN's HDR filter on linear radiance ``image``, with albedo and normal as guides."""
    try:
        import pyoidn
    except ImportError:
        raise GmcptError("OIDN (the path tracing + OIDN baseline, train.reference_denoiser=\"oidn\") needs "
                         "pyoidn: pip install -e '.[dev]'") from None
    contiguous = lambda array: np.ascontiguousarray(array, dtype=np.float32)  # noqa: E731
    return np.asarray(pyoidn.denoise(contiguous(image), contiguous(albedo), contiguous(normal), hdr=True),
                      dtype=np.float32)


def clean_reference(example: dict, denoiser: str) -> np.ndarray:
    """A dataset example's reference, denoised by ``denoiser`` (one of :data:`REFERENCE_DENOISERS`).

    A training reference averages a few hundred samples a pixel, which leaves sunlit interiors
    speckled (indirect-only sun patches); OIDN on it, guided by the example's 4-spp albedo and
    normal, removes the speckle (measured at 256x256 against 4096-spp references, 512-spp input:
    Cornell box 42.1 -> 46.6 dB, still life 40.7 -> 43.0, breakfast room 35.1 -> 38.0). Negative
    values OIDN may leave are clipped to 0. Deterministic (the same input gives the same bits).
    """
    if denoiser not in REFERENCE_DENOISERS:
        raise ValueError(f"reference denoiser must be one of {', '.join(REFERENCE_DENOISERS)}, got {denoiser!r}")
    reference = example["reference"]
    if denoiser == "none":
        return reference
    return np.maximum(denoise_oidn(reference, example["albedo"], example["normal"]), 0.0)
