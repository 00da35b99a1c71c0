"""The completion hook: a registry of reconstruction methods keyed by name.

Each method is a plain function ``fn(frame: SparseFrame, **options) ->
Completion``. :func:`complete` checks the frame once for all of them
(:func:`~gmcpt.completion.check.check_frame`: the image must be at least the
method's ``min_size``, non-finite samples are dropped from the mask), times
the call and checks the result. The options a caller will pass (method name,
generator weights) are checked by :func:`~gmcpt.completion.check.check_options`.

Methods shipped: ``none`` (the sparse image as is) and ``interp``
(feature-guided interpolation) in :mod:`~gmcpt.completion.classical`;
``pawnnm``, ``nnm`` and ``liu`` (a fill, then patch-group matrix completion)
in :mod:`~gmcpt.completion.matrix`; ``gan`` and ``gan_pawnnm`` in
:mod:`~gmcpt.completion.learned`; ``gan_oidn`` (the default) and ``gan_pawnnm_oidn`` (a fill, the
traced samples, then Intel OIDN) in :mod:`~gmcpt.completion.denoised`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
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
#: the method of the CLI, the scene XML and the Python API when none is named
DEFAULT_METHOD = "gan_oidn"


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


def complete(frame: SparseFrame, method: str = DEFAULT_METHOD, tile: int | None = None, **options) -> Completion:
    """Run completion ``method`` on ``frame`` and return the completed image.

    ``tile``: complete frames larger than ``tile`` x ``tile`` pixels in overlapping tiles of at most that
    side, blended (:mod:`gmcpt.completion.tiles`); None or 0 completes the whole frame at once.
    """
    from .tiles import DEFAULT_OVERLAP, complete_in_tiles

    entry = get_method(method)
    frame = check_frame(frame, method)
    height, width = frame.shape
    start = time.perf_counter()
    if tile and max(height, width) > tile:
        if tile < max(entry.min_size, 2 * DEFAULT_OVERLAP):
            raise GmcptError(f"tile {tile} is too small: at least {max(entry.min_size, 2 * DEFAULT_OVERLAP)} "
                             f"pixels for {method!r}")
        image, timings = complete_in_tiles(frame, lambda part: entry.function(part, **options), tile)
        result = Completion(image, timings)
    else:
        result = entry.function(frame, **options)
    result.timings["completion_s"] = time.perf_counter() - start
    if result.image.shape != (height, width, 3) or not np.isfinite(result.image).all():
        raise GmcptError(f"completion method {method!r} returned an invalid image")
    return result


from .check import check_frame, check_options, check_size, check_weights, sanitize  # noqa: E402,F401
from . import classical, matrix  # noqa: E402,F401  (registers none, interp; pawnnm, nnm, liu)
from . import learned  # noqa: E402,F401  (registers gan, gan_pawnnm)
from . import denoised  # noqa: E402,F401  (registers gan_oidn, gan_pawnnm_oidn)
