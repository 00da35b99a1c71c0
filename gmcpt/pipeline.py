"""One frame end to end: render (:mod:`gmcpt.sampling`), then complete (:mod:`gmcpt.completion`).

The ``masked_path`` plugin, the ``render`` and ``batch`` commands, the regression suite and the evaluation all
reach the renderer through :func:`render_and_complete`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .completion import DEFAULT_METHOD, complete
from .frame import SparseFrame
from .sampling import RenderSettings, render_sparse_frame

#: The fewest seconds per pixel a completion has taken in this process (first guess: OIDN on 2 cores, about
#: 0.06 s at 256x256 and 1.9 s at 1920x1080): what a time budget keeps back for it. The fewest, as the first
#: completion in a process loads its denoiser and is many times slower than the next.
_completion_pace = {"seconds_per_pixel": 1.0e-6}


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
    (``options``: its keyword options). ``check(frame)`` runs between the two (it may raise)."""
    say = progress or (lambda message: None)
    start = time.perf_counter()
    frame, timings = render_sparse_frame(scene, integrator, sensor, settings, progress=say,
                                         completion_seconds=_completion_pace["seconds_per_pixel"] * frame_pixels(scene, sensor))
    if check is not None:
        check(frame)
    say(f"completing with {method!r}")
    completion_start = time.perf_counter()
    result = complete(frame, method, **(options or {}))
    pace = (time.perf_counter() - completion_start) / frame.mask.size
    _completion_pace["seconds_per_pixel"] = min(_completion_pace["seconds_per_pixel"], pace)
    timings = {**timings, **result.timings}
    if settings.time:
        frame.info["time_spent"] = time.perf_counter() - start
    return Rendered(frame, result.image, timings)


def frame_pixels(scene, sensor=None) -> int:
    """Pixels of the film of ``sensor`` (default: the scene's first)."""
    film = (sensor if sensor is not None else scene.sensors()[0]).film()
    width, height = film.crop_size()
    return int(width) * int(height)
