"""Any variant, one line (issue 48, item 3): a Mitsuba variant this machine cannot run (CUDA without a GPU, a
misspelled name) is one ``error:`` line and exit 2, never a traceback nor a fallback; help never needs a variant."""
import os
import subprocess
import sys

import pytest

from conftest import ROOT, STILL_LIFE
from gmcpt.errors import GmcptError
from reliability_helpers import assert_one_line, run_plain

RENDER = [STILL_LIFE, "--res", "16", "16", "--spp", "1", "--method", "interp", "-q"]
NO_CUDA = "needs a CUDA GPU, and Dr.Jit finds none on this machine; set it to llvm_ad_rgb, or unset it"


def _gmcpt(variant: str, *args):
    """``python -m gmcpt ARGS`` with ``$GMCPT_VARIANT`` set, Python's warnings shown."""
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONWARNINGS"}
    return subprocess.run([sys.executable, "-m", "gmcpt", *map(str, args)], capture_output=True, text=True, cwd=ROOT,
                          env={**environment, "GMCPT_VARIANT": variant}, timeout=300)


@pytest.fixture
def without_cuda():
    from gmcpt.runtime.variant import _cuda_available

    if _cuda_available():
        pytest.skip("this machine has a CUDA GPU: cuda_ad_rgb runs here")


@pytest.mark.parametrize("variant", ["cuda_ad_rgb", "llvm_ad_rbg", "scalar_rgb"])
@pytest.mark.parametrize("args", [["--help"], ["render", "--help"], ["batch", "-h"]], ids=["gmcpt", "render", "batch"])
def test_help_never_needs_a_variant(variant, args):
    result = _gmcpt(variant, *args)
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert result.stdout.startswith("usage: gmcpt")


def test_cuda_without_a_gpu_is_one_line(without_cuda, tmp_path):
    for result in (_gmcpt("cuda_ad_rgb", "render", *RENDER, "--out", tmp_path / "out.exr"),
                   run_plain(*RENDER, "--out", tmp_path / "out.exr", env={"GMCPT_VARIANT": "cuda_ad_rgb"})):
        assert_one_line(result.returncode, result.stderr, f"GMCPT_VARIANT=cuda_ad_rgb {NO_CUDA}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("variant, hint", [("llvm_ad_rbg", "did you mean llvm_ad_rgb? "), ("scalar_rgb", "")])
def test_a_variant_gmcpt_does_not_run_in_is_one_line(tmp_path, variant, hint):
    result = run_plain(*RENDER, "--out", tmp_path / "out.exr", env={"GMCPT_VARIANT": variant})
    line = assert_one_line(result.returncode, result.stderr, f"GMCPT_VARIANT={variant} is not a Mitsuba variant")
    assert line.endswith(f"gmcpt runs in; {hint}use one of llvm_ad_rgb, cuda_ad_rgb, or unset it")
    assert list(tmp_path.iterdir()) == []


def test_an_empty_variant_is_as_if_unset(tmp_path):
    result = run_plain(*RENDER, "--out", tmp_path / "out.exr", env={"GMCPT_VARIANT": ""})
    assert result.returncode == 0, result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr", "out.json", "out.png"]


def test_library_callers_get_the_same_error(monkeypatch):
    from gmcpt.runtime import variant

    monkeypatch.setattr(variant, "_cuda_available", lambda: False)
    with pytest.raises(GmcptError, match=f"^GMCPT_VARIANT=cuda_ad_rgb {NO_CUDA}$"):
        variant.check_wanted("cuda_ad_rgb")
    variant.check_wanted("llvm_ad_rgb")  # runs everywhere gmcpt does
