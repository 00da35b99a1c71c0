"""One frame end to end: render (:mod:`gmcpt.sampling.strategies`), then complete (:mod:`gmcpt.completion`).

The ``masked_path`` plugin, the ``render`` and ``batch`` commands, the regression suite and the evaluation all
reach the renderer through :func:`render_and_complete`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .completion import DEFAULT_METHOD, complete
from .frame import SparseFrame
from .sampling.strategies import RenderSettings, render_sparse_frame


@dataclass
class Rendered:
    """A completed frame: the sparse frame, the completed (H, W, 3) image, and every stage's seconds."""

    frame: SparseFrame
    image: np.ndarray
    timings: dict


def render_and_complete(scene, integrator, settings: RenderSettings = RenderSettings(), method: str = DEFAULT_METHOD,
                        options: dict | None = None, sensor=None, progress: Callable[[str], None] | None = None,
                        check: Callable[[SparseFrame], None] | None = None) -> Rendered:
    """Render ``scene`` with ``integrator`` (the path tracer) under ``settings``, then complete it with ``method``
    (``options``: its keyword options). ``check(frame)`` runs between the two (it may raise). Nothing of the frame
    is kept for the next: the same settings give the same image whatever this process rendered before."""
    say = progress or (lambda message: None)
    start = time.perf_counter()
    frame, timings = render_sparse_frame(scene, integrator, sensor, settings, progress=say)
    if check is not None:
        check(frame)
    say(f"completing with {method!r}")
    result = complete(frame, method, **(options or {}))
    timings = {**timings, **result.timings}
    if settings.time:
        frame = replace(frame, info=frame.info.with_values(time_spent=time.perf_counter() - start))
    return Rendered(frame, result.image, timings)

