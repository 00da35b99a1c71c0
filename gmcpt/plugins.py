"""Mitsuba plugins registered through the ``mitsuba.plugins`` entry points.

The ``masked_path`` integrator lives in the :mod:`mitsuba_plugins` package,
which imports this library; the library never imports it back. The project's
``pyproject.toml`` declares it under the ``mitsuba.plugins`` entry-point group,
which Mitsuba 3.10 and later loads by itself; :func:`register_plugins` loads the
same entry points for the Mitsuba 3.9 the project pins (``import gmcpt`` calls
it once the variant is set).
"""
from __future__ import annotations

from importlib import metadata

from .errors import GmcptError

GROUP = "mitsuba.plugins"

#: (variant, plugin name) of every plugin registered so far
_registered: set[tuple[str, str]] = set()


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
