"""One pytest test per scene of a suite.

.. code-block:: python

    import pytest
    from gmcpt.regress import assert_scene, pytest_cases

    @pytest.mark.parametrize("case", pytest_cases("scenes"))
    def test_scene(case):
        assert_scene(case)

A scene that regressed fails its test with the metric, its value and
threshold, and the path of an HTML report of that scene; an optional scene
whose file is absent is skipped with the reason; a missing golden or a changed
resolution is an error naming it.
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

from .manifest import load_suite


@dataclass(frozen=True)
class Case:
    """A scene of a suite, as a test parameter."""

    folder: Path
    name: str

    def __str__(self) -> str:
        return self.name


def pytest_cases(folder, names: list[str] | None = None) -> list:
    """``pytest.param`` per scene of the suite in ``folder`` (all scenes, or ``names``), ids the scene names.

    Reads the folder and the manifest only (nothing renders at collection); an optional scene whose file
    is absent carries a skip mark with the reason.
    """
    import pytest

    suite = load_suite(folder)
    cases = []
    for name in suite.select(names):
        reason = suite.skip_reason(name)
        cases.append(pytest.param(Case(Path(folder), name), id=name,
                                  marks=[pytest.mark.skip(reason=reason)] if reason else []))
    return cases


def default_report_dir() -> Path:
    return Path(tempfile.gettempdir()) / "gmcpt-regress"


def assert_scene(case: Case, seed: int = 0, report_dir: str | Path | None = None):
    """Check ``case``; raise AssertionError naming the failed metrics, thresholds and the report written.

    The report (one scene, :func:`gmcpt.regress.report.write_html`) goes to
    ``report_dir/SUITE-SCENE.html`` (default: ``$TMPDIR/gmcpt-regress``). Returns the SceneResult.
    """
    from .report import failure_text, write_html
    from .run import check_suite

    [result] = check_suite(load_suite(case.folder), [case.name], seed)
    if result.skipped:
        import pytest

        pytest.skip(result.skipped)
    if not result.passed:
        folder = Path(report_dir) if report_dir is not None else default_report_dir()
        folder.mkdir(parents=True, exist_ok=True)
        report = write_html(folder / f"{Path(case.folder).resolve().name}-{case.name}.html", [result],
                            title=f"gmcpt regress: {case.name}")
        raise AssertionError(f"scene {case.name} regressed (seed {seed}): {failure_text(result)}; report {report}")
    return result
