"""Every shell and Python example in the README runs as written, in a fresh copy of the scenes.

A fence's info string says how: ```` ```sh ```` runs in ``make test``, ```` ```sh slow ```` in
``make test-slow`` only, and ```` ```sh no-test: REASON ```` not at all (set-up, hour-long builds,
clusters). Shell examples run as after ``make demo`` and ``. .venv/bin/activate`` (this interpreter's
folder first on ``PATH``), in a folder holding a copy of ``scenes/`` and the ``out/`` that ``make demo``
makes; each ``--out``/``--report`` file they name must exist afterwards.
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT

FENCE = re.compile(r"(?ms)^```(\w+)([^\n]*)\n(.*?)^```$")
RUNNERS = {"sh": ["bash", "-e", "-o", "pipefail", "-c"], "python": [sys.executable, "-c"]}


def examples() -> list[tuple[str, str, str]]:
    """(language, info after it, code) of every fenced block of the README."""
    return [(match[1], match[2].strip(), match[3]) for match in FENCE.finditer((ROOT / "README.md").read_text())]


def _cases():
    cases = []
    for index, (language, info, code) in enumerate(examples()):
        if language not in RUNNERS or info.startswith("no-test:"):
            continue
        marks = [pytest.mark.slow] if info == "slow" else []
        cases.append(pytest.param(language, code, marks=marks, id=f"{index}-{code.split()[0]}-{code.split()[1]}"))
    return cases


def test_every_example_runs_or_says_why_not():
    infos = [(language, info) for language, info, _ in examples()]
    assert all(info in ("", "slow") or re.fullmatch(r"no-test: \w.+", info) for _, info in infos), infos
    skipped = [info for language, info in infos if language in RUNNERS and info.startswith("no-test:")]
    # set-up, the real scenes' download, the hour-long dataset build, the two-node cluster
    assert len(skipped) <= 4, skipped
    assert {language for language, _ in infos} <= set(RUNNERS) | {"xml"}


@pytest.mark.parametrize("language, code", _cases())
def test_readme_example_runs(language, code, tmp_path):
    shutil.copytree(ROOT / "scenes", tmp_path / "scenes")
    (tmp_path / "out").mkdir()
    environment = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
                   "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore"}
    result = subprocess.run([*RUNNERS[language], code], cwd=tmp_path, env=environment, capture_output=True,
                            text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-3000:]
    for written in re.findall(r"--(?:out|report) (\S+)", code):
        assert (tmp_path / written).exists(), written


def test_the_readme_stays_a_user_guide_of_at_most_12_kb():
    assert len((ROOT / "README.md").read_bytes()) <= 12 * 1024
