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
from .completion.denoised import oidn_guide_rays
from .denoise import takes_clean_guides
from .costs import frame_costs, record_denoise
from .frame import SparseFrame
from .sampling import RenderSettings, render_sparse_frame


#: sparse frames completed in this process so far
_warm = {"sparse frames": 0}


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
    frame, timings = render_sparse_frame(scene, integrator, sensor, settings, progress=say)
    if check is not None:
        check(frame)
    say(f"completing with {method!r}")
    result = complete(frame, method, **(options or {}))
    timings = {**timings, **result.timings}
    if "denoise_s" in timings:  # a method without OIDN says nothing of OIDN's pace
        record_denoise(timings["denoise_s"], frame.mask.size, large=takes_clean_guides(oidn_guide_rays(frame)))
    if "sparse_extra_s" in frame.info:  # what this sparse frame added to a dense one's work, the generator's included
        extra = frame.info.pop("sparse_extra_s") + timings.get("pre_completion_s", 0.0)
        if _warm["sparse frames"]:  # the first one in a process loads and compiles the generator
            frame_costs(scene, frame.mask.size).learn_extra(extra)
        _warm["sparse frames"] += 1
    if settings.time:
        frame.info["time_spent"] = time.perf_counter() - start
    return Rendered(frame, result.image, timings)

