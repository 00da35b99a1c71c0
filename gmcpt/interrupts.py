"""How the command line ends on a signal, in one place.

While the command line starts (the heavy imports: Dr.Jit, Mitsuba, torch, OpenEXR), Ctrl-C (SIGINT)
or SIGTERM ends the process at once with one line: nothing is written yet, and an exception raised
inside a native module's initialisation can crash the interpreter (Dr.Jit's does, with SIGSEGV).
From :func:`install` on (the work itself), SIGINT raises ``KeyboardInterrupt`` and SIGTERM
:class:`Terminated`, so ``finally`` blocks run and remove temporary files; the command line then
prints one line (``error: interrupted`` or ``error: terminated``) and exits 130 or 143. Once the
outputs are complete (:func:`settle`) a signal changes nothing: the command exits 0.

The standard library only: ``gmcpt/__init__`` wraps its imports in :func:`startup`. A library
caller's process keeps its own signal handling.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from pathlib import Path

from .errors import GmcptError

#: the scripts that are the command line (``python -m gmcpt`` is recognised by its ``-m``)
COMMANDS = ("render_and_complete.py", "gmcpt")


class Terminated(BaseException):
    """SIGTERM, raised in the main thread; like ``KeyboardInterrupt``, ``except Exception`` lets it through."""


def _terminate(signum, frame):
    raise Terminated()


def install() -> dict:
    """SIGINT raises ``KeyboardInterrupt``, SIGTERM :class:`Terminated`; returns the handlers replaced."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    previous = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _terminate)
    return previous


def restore(previous: dict) -> None:
    """Put back the handlers :func:`install` replaced."""
    for number, handler in previous.items():
        if handler is not None:
            signal.signal(number, handler)


def settle() -> None:
    """The command's outputs are complete: ignore SIGINT and SIGTERM from now on, so that it exits 0.

    Called with the signals deferred (:func:`held`), so one that arrived during the last rename is dropped too.
    """
    if threading.current_thread() is threading.main_thread():
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, signal.SIG_IGN)


def report(error: BaseException) -> int:
    """Print the one line for an interruption; its exit status (130 for Ctrl-C, 143 for SIGTERM)."""
    status, message = (143, "terminated") if isinstance(error, Terminated) else (130, "interrupted")
    print(f"error: {message}", file=sys.stderr, flush=True)
    return status


def is_command_line() -> bool:
    """True when this process runs the command line: ``python -m gmcpt``, render_and_complete.py, ``gmcpt``."""
    argv = list(getattr(sys, "orig_argv", []))
    if "-m" in argv[1:-1]:
        return argv[argv.index("-m", 1) + 1] == "gmcpt"
    return bool(sys.argv) and Path(sys.argv[0]).name in COMMANDS


def _exit_now(signum, frame):
    status, message = (143, b"terminated") if signum == signal.SIGTERM else (130, b"interrupted")
    os.write(2, b"error: " + message + b"\n")
    os._exit(status)


@contextlib.contextmanager
def startup():
    """Around the package's imports: in the command line, a signal or a failed set-up there is one line."""
    if not is_command_line():
        yield
        return
    if threading.current_thread() is threading.main_thread():
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, _exit_now)  # until install(): nothing to clean up yet
    try:
        yield
    except GmcptError as error:  # no usable LLVM or variant: the command line's one line, as for bad input
        print(f"error: {error}", file=sys.stderr, flush=True)
        raise SystemExit(2) from None


@contextlib.contextmanager
def held():
    """Defer SIGINT and SIGTERM (main thread, POSIX) until the block is done: renames that must not be cut."""
    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)
