"""Mitsuba plugins registered through the ``mitsuba.plugins`` entry points.

The ``masked_path`` integrator lives in the :mod:`mitsuba_plugins` package,
which imports this library; the library never imports it back. The project's
``pyproject.toml`` declares it under the ``mitsuba.plugins`` entry-point group,
which Mitsuba 3.10 and later loads by itself; :func:`register_plugins` loads the
same entry points for the Mitsuba 3.9 the project pins (``import gmcpt`` calls
it once the variant is set).

Mitsuba's loader turns an exception raised in a Python plugin's constructor into a
``RuntimeError`` whose message holds the Python traceback. :func:`constructor` keeps the
:class:`GmcptError` such a plugin raised (on whichever thread Mitsuba built it), and
:func:`plugin_errors` raises it again, as itself, where the scene or plugin was loaded.
"""
from __future__ import annotations

import contextlib
import threading
from importlib import metadata

from ..errors import GmcptError

GROUP = "mitsuba.plugins"

#: (variant, plugin name) of every plugin registered so far
_registered: set[tuple[str, str]] = set()
#: GmcptErrors raised by plugin constructors, which Mitsuba may run on its own threads
_failures: list[GmcptError] = []
_failures_lock = threading.Lock()


def register_plugins() -> list[str]:
    """Register every plugin of the ``mitsuba.plugins`` entry points with the active variant; their names."""
    import mitsuba as mi

    names = []
    for entry in metadata.entry_points(group=GROUP):
        if (mi.variant(), entry.name) not in _registered:
            entry.load()()
            _registered.add((mi.variant(), entry.name))
        names.append(entry.name)
    return names


def require_plugin(name: str) -> None:
    """Raise (one line) unless plugin ``name`` is registered with the active variant."""
    import mitsuba as mi

    if (mi.variant(), name) not in _registered and name not in register_plugins():
        raise GmcptError(f"the Mitsuba plugin {name!r} is not registered: install the project "
                         f"(pip install -e .) so that its {GROUP!r} entry point is found")


def constructor(cls):
    """A Mitsuba plugin factory for ``cls`` that keeps the :class:`GmcptError` its constructor raises."""
    def make(props):
        try:
            return cls(props)
        except GmcptError as error:
            with _failures_lock:
                _failures[:] = [*_failures[-7:], error]
            raise
    return make


def mitsuba_message(error: BaseException) -> str:
    """A Mitsuba error on one line, without the Python traceback it may carry (its last line kept)."""
    text = str(error)
    head, marker, tail = text.partition("Traceback (most recent call last):")
    if marker:
        text = head + (tail.strip().splitlines() or [""])[-1]
    return " ".join(text.split())


@contextlib.contextmanager
def plugin_errors(prefix: str = ""):
    """Raise a plugin's :class:`GmcptError` (after ``prefix``) in place of the error Mitsuba's loader made of it."""
    try:
        yield
    except RuntimeError as error:
        with _failures_lock:
            original = next((failure for failure in reversed(_failures) if str(failure) in str(error)), None)
            _failures.clear()
        if original is None:
            raise
        raise GmcptError(prefix + str(original)) from None
