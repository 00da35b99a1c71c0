"""How the command line ends on a signal, in one place.

While the command line starts (the heavy imports: Dr.Jit, Mitsuba, torch, OpenEXR), Ctrl-C (SIGINT)
or SIGTERM ends the process at once with one line: nothing is written yet, and an exception raised
inside a native module's initialisation can crash the interpreter (Dr.Jit's does, with SIGSEGV).
From :func:`install` on (the work itself), SIGINT raises ``KeyboardInterrupt`` and SIGTERM
:class:`Terminated` (outside imports and :func:`held` blocks, which they wait for), so ``finally``
blocks run and remove temporary files; the command line then
prints one line (``error: interrupted`` or ``error: terminated``) and exits 130 or 143. Once the
outputs are complete (:func:`settle`), and once the command has its exit status (:func:`restore`), a
signal changes nothing: the command exits 0, or with that status.

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

from ..errors import GmcptError

#: the scripts that are the command line (``python -m gmcpt`` is recognised by its ``-m``)
COMMANDS = ("render_and_complete.py", "gmcpt")


class Terminated(BaseException):
    """SIGTERM, raised in the main thread; like ``KeyboardInterrupt``, ``except Exception`` lets it through."""


#: how many :func:`held` blocks the main thread is in, and the signals that arrived meanwhile
_holding = 0
_deferred: list[int] = []
#: the signals received since :func:`install`
_received: list[int] = []
#: a signal that arrives inside an import is sent again this many seconds later, until the import is done
RETRY_S = 0.05


def _importing(frame) -> bool:
    """True while the main thread runs an import: an exception raised there can leave a native module
    half made (crashing the interpreter at exit) or be read as a missing package (a wrong fallback)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _interrupt(signum, frame):
    """From :func:`install` on: raise ``KeyboardInterrupt`` or :class:`Terminated`, at a point where it is safe."""
    _received.append(signum)
    if _holding:
        _deferred.append(signum)
    elif _importing(frame):
        retry = threading.Timer(RETRY_S, signal.raise_signal, (signum,))
        retry.daemon = True
        retry.start()
    else:
        raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


def install() -> dict:
    """SIGINT raises ``KeyboardInterrupt``, SIGTERM :class:`Terminated`; returns the handlers replaced."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    previous = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    _received.clear()
    for number in previous:
        signal.signal(number, _interrupt)
    return previous


def restore(previous: dict) -> None:
    """Put back the handlers :func:`install` replaced; in the command line ignore the signals instead.

    The command line's exit status is decided by now, and at exit Python resets its own handlers to
    the default, so a signal while the process winds down (a second or more on a busy machine) would
    otherwise kill it with nothing said.
    """
    if is_command_line():
        settle()
        return
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


def interruption() -> BaseException | None:
    """The ``KeyboardInterrupt`` or :class:`Terminated` of the first signal since :func:`install`; None if none came.

    Native code turns one raised in a callback into its own error (Dr.Jit's custom operations, which
    Mitsuba's render is, chain it; Mitsuba's scene parser keeps its name in a message), so an error
    after a signal is that signal's.
    """
    if not _received:
        return None
    return KeyboardInterrupt() if _received[0] == signal.SIGINT else Terminated()


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


#: in the command line, why the package's set-up failed (no usable LLVM or variant): said by
#: :func:`gmcpt.cli.main` in one line, unless the command line only asks for help
startup_error: GmcptError | None = None


@contextlib.contextmanager
def startup():
    """Around the package's imports: in the command line, a signal there is one line, and a failed
    set-up is kept in :data:`startup_error` (the rest of the block skipped) for the command to say."""
    global startup_error
    if not is_command_line():
        yield
        return
    if threading.current_thread() is threading.main_thread():
        for number in (signal.SIGINT, signal.SIGTERM):
            signal.signal(number, _exit_now)  # until install(): nothing to clean up yet
    try:
        yield
    except GmcptError as error:
        startup_error = error


@contextlib.contextmanager
def held():
    """Defer SIGINT and SIGTERM (main thread) until the block is done: renames that must not be cut.

    The main thread's mask keeps them from any handler; a signal another thread (Dr.Jit's, torch's)
    receives still runs :func:`_interrupt`, which waits for the block's end too.
    """
    global _holding
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    masking = hasattr(signal, "pthread_sigmask")
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM}) if masking else None
    _holding += 1
    try:
        yield
    finally:
        _holding -= 1
        if masking:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)
        if not _holding and _deferred:
            signum = _deferred[0]
            _deferred.clear()
            signal.raise_signal(signum)  # to the handler now in place: none once settle() has run
