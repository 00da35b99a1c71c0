"""A timed sequence's pace: what its frames so far cost, to size the next frame's samples to a time
(:class:`FramePace`, :attr:`gmcpt.temporal.sequence.SequenceSettings.time`)."""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from ..sampling.budget import MAX_BUDGET

#: The fewest and most samples a pixel a timed frame spends (below the fewest the frame is late; a warning says so).
TIMED_BUDGETS = (0.25, float(MAX_BUDGET))
#: Frames whose costs :class:`FramePace` reads
PACE_FRAMES = 3
#: Budgets this far apart (the largest over the smallest) tell the path tracing's launch from its samples
PACE_SPREAD = 2.0


@dataclass
class FramePace:
    """What a sequence's frames cost, read from the frames so far, to size the next frame's samples to a time.

    A frame's period runs from the end of the frame before to its own end, so it holds what the caller does between
    frames (loading the next scene, writing the last frame's files) as well as the frame itself. Its seconds split
    into the path tracing and the rest (the least of the last :data:`PACE_FRAMES` frames': a slow frame, the first
    compiling its kernels or one in a busy moment, would starve the next of samples). The path tracing's seconds
    are a line in the samples, read from those frames: where their budgets lie apart (a sequence still finding
    its pace) the line through them, whose launch cost a small budget's seconds a sample would count as samples;
    else the median seconds a sample.

    The plan is a guess at what the frame will cost; the frame holds to its time by a deadline (:meth:`deadline`):
    its path tracing goes in passes and stops where the next would end past it, or goes on while there is time, so
    that a moment the machine runs slower or faster moves the frame's samples, not its seconds."""

    ended: float | None = None  # perf_counter() at the end of the last frame
    fixed: deque = field(default_factory=lambda: deque(maxlen=PACE_FRAMES))  # seconds a frame besides its samples
    traced: deque = field(default_factory=lambda: deque(maxlen=PACE_FRAMES))  # (budget, seconds tracing it)
    tails: deque = field(default_factory=lambda: deque(maxlen=PACE_FRAMES))  # seconds from the tracing's end to the frame's

    def deadline(self, seconds: float, started: float) -> float | None:
        """When (perf_counter) a frame of ``seconds`` that started at ``started`` should end its path tracing: its
        period's end less the lower median of the times the last frames took after their tracing (the least left
        frames of a quarter second 2% long on the mean; the mean of two counts a first frame's cold start). None
        before a frame was measured, or after a pause (:meth:`_follows`)."""
        if not self.tails or not self._follows(started, seconds):
            return None
        return self.ended + seconds - sorted(self.tails)[(len(self.tails) - 1) // 2]

    def _follows(self, started: float, seconds: float) -> bool:
        """Whether a frame that started at ``started`` follows the last one within its period: a gap of more than
        twice ``seconds`` is a pause (the caller waited on something else), not the caller's share of a frame."""
        return self.ended is not None and started - self.ended <= 2 * seconds

    def budget(self, seconds: float, first: float) -> float:
        """Samples a pixel for a frame of ``seconds``; ``first`` until a frame has been measured."""
        if not self.traced:
            return first
        return self._samples(seconds - min(self.fixed))

    def budget_until(self, deadline: float, now: float) -> float:
        """Samples a pixel that the path tracing can spend from ``now`` to ``deadline`` (perf_counter)."""
        return self._samples(deadline - now)

    def _samples(self, seconds: float) -> float:
        """Samples a pixel that ``seconds`` of path tracing buy, within :data:`TIMED_BUDGETS`."""
        launch, per_sample = self._tracing()
        low, high = TIMED_BUDGETS
        return float(np.clip((seconds - launch) / per_sample, low, high))

    def _tracing(self) -> tuple[float, float]:
        """(seconds of a launch, seconds a sample a pixel) of the path tracing in the frames so far."""
        budgets, spent = (np.array(column, np.float64) for column in zip(*self.traced))
        if budgets.max() >= PACE_SPREAD * budgets.min():
            per_sample, launch = np.polyfit(budgets, spent, 1)
            if per_sample > 0:
                return max(float(launch), 0.0), float(per_sample)
        return 0.0, max(float(np.median(spent / budgets)), 1e-9)

    def record(self, started: float, ended: float, render_s: float, budget: float, seconds: float,
               traced: float) -> None:
        """A frame that ran from ``started`` to ``ended`` (perf_counter), ``render_s`` of it tracing ``budget``
        samples a pixel up to ``traced`` (perf_counter), in a sequence of ``seconds`` a frame; the gap before it
        counts, but for a pause (:meth:`_follows`)."""
        period = ended - started
        if self._follows(started, seconds):
            period += started - self.ended
        self.ended = ended
        self.fixed.append(period - render_s)
        self.traced.append((budget, render_s))
        self.tails.append(ended - traced)
