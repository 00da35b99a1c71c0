"""The checks on a completion's input, in one place: the options a caller passes and the frame.

:func:`check_options` runs where the options arrive (the command line, the
``masked_path`` plugin's properties), before anything renders;
:func:`check_frame` runs once in :func:`gmcpt.completion.complete`, so no
method checks its frame itself.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import GmcptError
from ..frame import SparseFrame
from . import get_method


def check_options(method: str | None, weights: str | None) -> None:
    """Raise (one line) on an unknown ``method`` or ``weights`` it cannot take (None: not given)."""
    if method is not None:
        get_method(method)
    if weights is not None:
        check_weights(method, weights)


def check_weights(method: str | None, weights: str) -> None:
    """Raise (one line) unless ``method`` takes generator weights and ``weights`` is a file that matches the
    sha256 of its record, or, without one, loads.

    ``method`` None checks the file alone (the method is not known yet).
    """
    if method is not None and not get_method(method).takes("weights"):
        raise GmcptError(f"weights apply to the GAN methods only, not to completion {method!r}")
    from ..gan.names import checked_weights

    if not checked_weights(weights)[1].get("sha256"):  # no record to check the bytes against: torch loads them
        from ..gan.weights import load_generator

        load_generator(weights)


def check_size(method: str, height: int, width: int) -> None:
    """Raise if an image of this size is too small for ``method`` (e.g. its patch)."""
    needed = get_method(method).min_size
    if min(height, width) < needed:
        raise GmcptError(f"image {width}x{height} is smaller than method {method!r} needs "
                         f"(at least {needed}x{needed}, its patch size)")


def sanitize(frame: SparseFrame) -> SparseFrame:
    """Drop non-finite samples from the mask and zero non-finite features."""
    buffers = (frame.radiance, frame.variance, frame.albedo, frame.normal, frame.depth, frame.visibility)
    if all(np.isfinite(buffer).all() for buffer in buffers):
        return frame
    finite = np.isfinite(frame.radiance).all(axis=-1) & np.isfinite(frame.variance)
    mask = frame.mask & finite
    clean = lambda a: np.nan_to_num(a, nan=0.0, posinf=0.0, neginf=0.0).astype(np.float32)  # noqa: E731
    radiance = np.where(mask[..., None], clean(frame.radiance), 0.0).astype(np.float32)
    info = frame.info.with_values(dropped_nonfinite_pixels=int((frame.mask & ~finite).sum()))
    return replace(frame, radiance=radiance, mask=mask, variance=np.where(mask, clean(frame.variance), 0.0),
                   albedo=clean(frame.albedo), normal=clean(frame.normal), depth=clean(frame.depth),
                   visibility=clean(frame.visibility), info=info)


def check_frame(frame: SparseFrame, method: str) -> SparseFrame:
    """The frame ``method`` gets: large enough for it, non-finite samples dropped, at least one sample left.

    Raises
    ------
    GmcptError
        One line, when the image is smaller than the method's ``min_size`` or no finite sample is left.
    """
    height, width = frame.shape
    check_size(method, height, width)
    frame = sanitize(frame)
    if not frame.mask.any():
        raise GmcptError("no finite rendered samples to complete from")
    return frame
