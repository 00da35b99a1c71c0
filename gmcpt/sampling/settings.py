"""What a frame traces: :class:`RenderSettings` (rate, pattern, seed, samples, budget, time, costs) and the one rule of
the sample counts (:func:`check_one_sample_count`). Read by the strategies (:mod:`gmcpt.sampling.strategies`, which
exports them too) and the frame's trace (:class:`gmcpt.sampling.trace.FrameTrace`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from ..errors import GmcptError
from ..frame import DEFAULT_FEATURE_SPP
from ..limits import check_feature_spp, check_seconds, check_seed, check_spp
from .budget import check_budget
from .costs import CostModel
from .masks import DEFAULT_PATTERN, DEFAULT_RATE, check_pattern, check_rate

#: A progress callback: one status line.
Say = Callable[[str], None]


@dataclass(frozen=True)
class RenderSettings:
    """What to trace. ``spp=0`` keeps the sensor's sample count. A ``budget`` (mean path samples a pixel, 0: none)
    replaces ``rate`` and ``spp``: :mod:`gmcpt.sampling.budget` chooses them per frame, with the ``two_pass`` mask,
    weighing time with ``costs`` (None: this machine's stored model, :func:`gmcpt.sampling.costs.machine_costs`), as a
    time budget does for its first estimate of OIDN's seconds.

    Checked when made (:mod:`gmcpt.limits`): a bad value raises a one-line :class:`~gmcpt.errors.GmcptError`.
    """

    rate: float = DEFAULT_RATE
    pattern: str = DEFAULT_PATTERN
    seed: int = 0
    spp: int = 0
    feature_spp: int = DEFAULT_FEATURE_SPP
    budget: float = 0.0
    time: float = 0.0  # seconds of wall time for the frame and its completion; 0: none
    costs: CostModel | None = None

    def __post_init__(self):
        check_rate(self.rate)
        check_pattern(self.pattern)
        check_seed(self.seed)
        if self.spp != 0:
            check_spp(self.spp)
        check_feature_spp(self.feature_spp)
        if self.budget:
            check_budget(self.budget)
            if self.pattern != "two_pass":
                raise GmcptError(f"a budget places its samples with the two_pass mask, not {self.pattern!r}")
        if self.time:
            check_seconds(self.time)
        check_one_sample_count(spp=self.spp, budget=self.budget, time=self.time)


def check_one_sample_count(names: dict | None = None, **given) -> None:
    """The one rule of the sample counts: ``budget`` and ``time`` each set the samples a pixel themselves, so
    neither goes with the other, with ``spp`` or with ``rate``. ``given``: the values (None or 0: not given);
    ``names``: how the caller names them (the command line's ``--budget``), in the one-line error."""
    names = names or {}
    chosen = [name for name in ("time", "budget", "rate", "spp") if given.get(name)]
    if len(chosen) > 1 and chosen[0] in ("time", "budget"):
        first, second = (names.get(name, name) for name in chosen[:2])
        raise GmcptError(f"{first} sets the samples a pixel itself: give {first} or {second}, not both")
