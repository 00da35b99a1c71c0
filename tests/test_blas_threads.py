"""OpenBLAS's threads sleep right after a call (gmcpt/__init__): their busy-wait took a core from the next render."""
import os
import subprocess
import sys

import pytest

PRINT = "import gmcpt, os; print(os.environ.get('OPENBLAS_THREAD_TIMEOUT'))"


@pytest.mark.parametrize("preset,expected", [(None, "4"), ("9", "9")])
def test_importing_gmcpt_sets_openblas_threads_to_sleep_unless_the_user_chose(preset, expected):
    env = {key: value for key, value in os.environ.items() if key != "OPENBLAS_THREAD_TIMEOUT"}
    if preset is not None:
        env["OPENBLAS_THREAD_TIMEOUT"] = preset
    result = subprocess.run([sys.executable, "-c", PRINT], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip().splitlines()[-1] == expected


WATCH = """
import importlib.abc, os, sys
class Watch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == "numpy":
            print("numpy loads with", os.environ.get("OPENBLAS_THREAD_TIMEOUT"))
            sys.meta_path.remove(self)
sys.meta_path.insert(0, Watch())
import gmcpt
"""


def test_numpy_loads_after_the_setting():
    env = {key: value for key, value in os.environ.items() if key != "OPENBLAS_THREAD_TIMEOUT"}
    result = subprocess.run([sys.executable, "-c", WATCH], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "numpy loads with 4" in result.stdout
