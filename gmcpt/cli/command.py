"""What every ``gmcpt SUBCOMMAND`` shares: its parser, its exit status, its progress lines.

Bad input ends with one ``error: ...`` line on stderr and exit status 2; no
output file is written or replaced. Ctrl-C ends a command with ``error:
interrupted`` (exit 130), SIGTERM with ``error: terminated`` (143), temporary
files removed; once a command's outputs are complete it exits 0 whatever
arrives (:func:`gmcpt.runtime.interrupts.settle`). The standard library only, so that
``gmcpt --help`` and a refused command line answer at once.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable

from ..errors import GmcptError
from ..runtime import interrupts

EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 1


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions as written; an option with a default says it, unless its help already does."""

    def _get_help_string(self, action):
        help_text = action.help or ""
        default = action.default
        unset = default is None or default is False or default is argparse.SUPPRESS or default == []
        if "default" in help_text or unset or not action.option_strings:
            return help_text
        shown = " ".join(map(str, default)) if isinstance(default, (list, tuple)) else default
        return f"{help_text} (default: {shown})"


class Parser(argparse.ArgumentParser):
    """The parser of ``gmcpt NAME``: a refusal is one line and exit status 2 (:func:`exit_status`)."""

    def __init__(self, name: str, description: str, **kwargs):
        super().__init__(prog=f"gmcpt {name}", description=description, formatter_class=_HelpFormatter, **kwargs)

    def error(self, message):
        raise GmcptError(message)


def exit_status(body: Callable[[], int], start_up: Callable[[], None] | None = None) -> int:
    """Run a command: ``start_up`` (parsing, the heavy imports), then ``body`` with signals handled
    (:mod:`gmcpt.runtime.interrupts`). Bad input or the environment become one ``error:`` line and status 2,
    Ctrl-C 130, SIGTERM 143, a crash one line and 1."""
    handlers = {}
    try:
        if start_up is not None:
            start_up()
        handlers = interrupts.install()  # from here a signal raises, and no temporary file is left behind
        return body()
    except (KeyboardInterrupt, interrupts.Terminated) as error:
        return interrupts.report(error)
    except Exception as error:
        if (interruption := interrupts.interruption()) is not None:  # the signal, under another name
            return interrupts.report(interruption)
        return _refusal(error)
    finally:
        interrupts.restore(handlers)


def _refusal(error: Exception) -> int:
    """Print the one line for ``error``, raised by a command; its exit status."""
    if isinstance(error, GmcptError):
        print(f"error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(error, MemoryError):  # the estimate (gmcpt.limits) let through a run this machine cannot hold
        print("error: out of memory; lower the resolution (--res), or free memory", file=sys.stderr)
        return EXIT_BAD_INPUT
    if isinstance(error, OSError):  # the environment: a file that cannot be read, a device that fails
        where = f" ({error.filename})" if error.filename else ""
        print(f"error: {error.strerror or error}{where}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if os.environ.get("GMCPT_DEBUG"):  # an internal error is still one line, unless debugging
        raise error
    message = " ".join(str(error).split()) or type(error).__name__
    print(f"error: internal error ({type(error).__name__}): {message} (set GMCPT_DEBUG=1 for a traceback)",
          file=sys.stderr)
    return EXIT_INTERNAL


def stamped_say(label: str, quiet: bool = False) -> Callable[[str], None]:
    """A ``say`` that prints ``[label   1.2s] message`` on stderr (seconds since now); silent if ``quiet``."""
    start = time.perf_counter()

    def say(message: str) -> None:
        if not quiet:
            print(f"[{label} {time.perf_counter() - start:6.1f}s] {message}", file=sys.stderr, flush=True)
    return say


def start_mitsuba() -> None:
    """Import gmcpt (LLVM, variant, plugin registration) and quieten Mitsuba's log."""
    import gmcpt  # noqa: F401
    import mitsuba as mi
    import OpenEXR  # noqa: F401  (native modules are imported before signals raise: see gmcpt.runtime.interrupts)
    mi.set_log_level(mi.LogLevel.Error)


def mitsuba_command(argv: list[str], build_parser: Callable[[], argparse.ArgumentParser],
                    work: Callable[[argparse.Namespace], int]) -> int:
    """Parse ``argv``, start Mitsuba, then ``work(args)``, under :func:`exit_status`."""
    parsed = {}

    def start_up() -> None:
        parsed["args"] = build_parser().parse_args(argv)
        start_mitsuba()
    return exit_status(lambda: work(parsed["args"]), start_up)
