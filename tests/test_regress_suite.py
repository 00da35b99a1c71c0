"""The project's own regression suite: scenes/ against the goldens in scenes/golden (96x96).

One test per scene (:func:`gmcpt.regress.pytest_cases`); the breakfast room, read from
../shared/scenes where present, is skipped with the reason where it is not. After an
intended change to a scene or to the renderer: ``python -m gmcpt regress scenes --update``.
"""
import pytest

from conftest import SCENES
from gmcpt.regress import assert_scene, pytest_cases


@pytest.mark.parametrize("case", pytest_cases(SCENES))
def test_bundled_scene_matches_its_golden(case, mi):
    assert_scene(case)
