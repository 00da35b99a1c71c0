"""Scene regression tests: cheap masked renders checked against golden images.

A suite is a folder of scene files with goldens in ``DIR/golden/``
(:mod:`gmcpt.regress.manifest`). ``python -m gmcpt regress DIR --update``
renders the goldens with plain path tracing and calibrates each scene's
thresholds on the check's own spread over seeds (:mod:`gmcpt.regress.measure`);
``python -m gmcpt regress DIR`` renders every scene cheaply (a masked render +
completion) and compares (:mod:`gmcpt.regress.run`, :mod:`gmcpt.regress.report`).
From pytest, :func:`pytest_cases` and :func:`assert_scene` make one test per scene.
"""
from __future__ import annotations

from .manifest import Settings, Suite, load_suite
from .measure import SceneResult
from .testing import Case, assert_scene, pytest_cases

__all__ = ["Settings", "Suite", "load_suite", "SceneResult", "Case", "pytest_cases", "assert_scene",
           "check_suite", "update_suite"]


def check_suite(folder, names=None, seed=0):
    """Check the scenes ``names`` (all when None) of the suite in ``folder``; a list of SceneResult."""
    from .run import check_suite as check

    return check(load_suite(folder), names, seed)


def update_suite(folder, names=None, **settings):
    """Make the goldens of the suite in ``folder`` (``settings``: fields of :class:`Settings` to change)."""
    from .manifest import with_settings
    from .run import update_suite as update

    suite = load_suite(folder)
    return update(suite, with_settings(suite, **settings), names)
