"""The completion hook: a registry of reconstruction methods keyed by name.

Each method is a plain function ``fn(frame: SparseFrame, **options) ->
Completion``. :func:`complete` validates the frame once for all of them
(non-finite samples are dropped from the mask, the image must be at least the
method's ``min_size``), times the call and checks the result.

Methods shipped here: ``none`` (the sparse image as is) and ``interp``
(feature-guided interpolation on demodulated radiance, see
:mod:`gmcpt.completion.classical`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..errors import GmcptError
from ..frame import SparseFrame


@dataclass
class Completion:
    """The output of a completion method.

    Attributes
    ----------
    image : (H, W, 3) float32 linear HDR radiance, every pixel filled.
    timings : seconds per sub-stage (e.g. ``block_matching_s``); ``complete``
        adds ``completion_s``, the whole call.
    """

    image: np.ndarray
    timings: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Method:
    name: str
    function: Callable[..., Completion]
    min_size: int
    summary: str

    def takes(self, option: str) -> bool:
        """True if the method accepts the keyword option ``option`` (e.g. ``weights``)."""
        import inspect

        return option in inspect.signature(self.function).parameters


_REGISTRY: dict[str, Method] = {}


def register_method(name: str, *, min_size: int = 1, summary: str = ""):
    """Decorator adding a completion function to the registry under ``name``.

    ``min_size`` is the smallest image side the method can handle (its patch
    size, for patch-based methods).
    """
    def decorator(function):
        first_doc_line = (function.__doc__ or name).strip().splitlines()[0]
        _REGISTRY[name] = Method(name, function, min_size, summary or first_doc_line)
        return function
    return decorator


def methods() -> list[str]:
    """Names of the registered completion methods."""
    return sorted(_REGISTRY)


def get_method(name: str) -> Method:
    if name not in _REGISTRY:
        raise GmcptError(f"unknown completion method {name!r}; choose from {', '.join(methods())}")
    return _REGISTRY[name]


def check_weights(method: str | None, weights: str) -> None:
    """Raise (one line) unless ``method`` takes generator weights and ``weights`` loads.

    ``method`` None checks the file alone (the method is not known yet).
    """
    if method is not None and not get_method(method).takes("weights"):
        raise GmcptError(f"weights apply to the GAN methods only, not to completion {method!r}")
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
    info = dict(frame.info, dropped_nonfinite_pixels=int((frame.mask & ~finite).sum()))
    return replace(frame, radiance=radiance, mask=mask, variance=np.where(mask, clean(frame.variance), 0.0),
                   albedo=clean(frame.albedo), normal=clean(frame.normal), depth=clean(frame.depth),
                   visibility=clean(frame.visibility), info=info)


def complete(frame: SparseFrame, method: str = "interp", **options) -> Completion:
    """Run completion ``method`` on ``frame`` and return the completed image."""
    entry = get_method(method)
    height, width = frame.shape
    check_size(method, height, width)
    frame = sanitize(frame)
    if not frame.mask.any():
        raise GmcptError("no finite rendered samples to complete from")
    start = time.perf_counter()
    result = entry.function(frame, **options)
    result.timings["completion_s"] = time.perf_counter() - start
    if result.image.shape != (height, width, 3) or not np.isfinite(result.image).all():
        raise GmcptError(f"completion method {method!r} returned an invalid image")
    return result


from . import classical, lowrank  # noqa: E402,F401  (registers none, interp, pawnnm, nnm)
from . import learned  # noqa: E402,F401  (registers gan, gan_pawnnm)
