"""Progress of long jobs: a tqdm bar on a terminal, log lines elsewhere, nothing under ``-q``.

One helper for the dataset build, training, the evaluation and ``batch``::

    with Progress(len(jobs), "batch", unit="frame", say=say, quiet=args.quiet) as bar:
        for result in results:
            bar.update(note=f"{result['name']} {result['seconds']:.1f}s")

On a terminal (``stream.isatty()``) the bar shows count, rate and time left,
and :meth:`Progress.write` prints a message above it without breaking it.
Elsewhere (a log file, a pipe, CI) every ``log_every``-th update (with its
note) becomes one line from :func:`status_line`, handed to ``say``; so does
each message. Quiet, nothing is printed at all.
"""
from __future__ import annotations

import sys
import time
from typing import Callable, TextIO


def format_seconds(seconds: float) -> str:
    """``42s``, ``3m07s`` or ``2h05m``; ``?`` for an unknown (negative or infinite) duration."""
    if not 0 <= seconds < float("inf"):
        return "?"
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


def status_line(desc: str, done: int, total: int | None, elapsed: float, unit: str = "it",
                note: str = "", initial: int = 0) -> str:
    """One log line: count, rate and time left of a job ``done`` of ``total`` (``None``: unknown).

    Parameters
    ----------
    desc : what runs, first on the line.
    done, total : units finished, out of ``total``.
    elapsed : seconds since the job (or its resumption) started.
    unit : name of one unit, for the rate.
    note : appended after a colon.
    initial : units already done when the clock started (a resumed job): left out of the rate.

    Returns
    -------
    str
        e.g. ``batch 3/8 frames: cornell-box 2.1s (0.45 frame/s, 11s left)``.
    """
    counted = done - initial
    rate = counted / elapsed if elapsed > 0 and counted > 0 else 0.0
    count = f"{done}/{total}" if total is not None else f"{done}"
    timing = f"{rate:.3g} {unit}/s" if rate else f"- {unit}/s"
    if total is not None:
        timing += f", {format_seconds((total - done) / rate if rate else float('inf'))} left"
    plural = unit if unit.endswith("s") else unit + "s"
    return f"{desc} {count} {plural}" + (f": {note}" if note else "") + f" ({timing})"


def is_terminal(stream: TextIO) -> bool:
    """True if ``stream`` is an interactive terminal (bars there, log lines elsewhere)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # a closed or a fake stream
        return False


class Progress:
    """Count finished units of a job; see the module docstring.

    Parameters
    ----------
    total : units in the job (``None``: unknown).
    desc : what runs (``batch``, ``dataset``, ``train``, ``eval``).
    unit : name of one unit.
    say : where log lines and messages go when no bar is drawn (default: ``stream``).
    quiet : print nothing.
    initial : units already done (a resumed job).
    log_every : without a bar, a line every this many updates (0: none; messages only).
    stream : the bar's stream and the terminal test (default ``sys.stderr``).
    """

    def __init__(self, total: int | None, desc: str, unit: str = "it", say: Callable[[str], None] | None = None,
                 quiet: bool = False, initial: int = 0, log_every: int = 1, stream: TextIO | None = None):
        self.total, self.desc, self.unit, self.quiet = total, desc, unit, quiet
        self.initial = self.done = initial
        self.log_every = log_every
        self.stream = stream or sys.stderr
        self.say = say or (lambda message: print(message, file=self.stream, flush=True))
        self.start = time.perf_counter()
        self.bar = None
        if not quiet and is_terminal(self.stream):
            from tqdm import tqdm
            self.bar = tqdm(total=total, desc=desc, unit=unit, initial=initial, file=self.stream,
                            dynamic_ncols=True, smoothing=0.1)

    def update(self, n: int = 1, note: str = "") -> None:
        """``n`` more units done; ``note`` (the unit just finished, a loss) goes on the bar or the line."""
        self.done += n
        if self.quiet:
            return
        if self.bar is not None:
            if note:
                self.bar.set_postfix_str(note, refresh=False)
            self.bar.update(n)
        elif self.log_every and (self.done - self.initial) % self.log_every == 0:
            self.say(status_line(self.desc, self.done, self.total, time.perf_counter() - self.start, self.unit,
                                 note, self.initial))

    def write(self, message: str) -> None:
        """A message: above the bar, or as a line through ``say``; nothing when quiet."""
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.write(message, file=self.stream)
        else:
            self.say(message)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
