"""scripts/device_check.sh (the one-call GPU check) dry-run on the CPU, and scripts/pack_device.py's dataset shard."""
import importlib.util
import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT
from gan_helpers import tiny_dataset

SCRIPT = ROOT / "scripts" / "device_check.sh"
RESULTS = {"gan-gpu-device.pt", "gan-gpu-device.json", "demo.exr", "demo.png", "demo.json", "curves.png",
           "device-check.log", "summary.json"}


def _run(*args, **env):
    return subprocess.run(["bash", str(SCRIPT), *args], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHON": sys.executable, **env})


@pytest.mark.slow  # 40 s here: `make test` stays under 15 min; `make test-slow` runs it
def test_dry_run_trains_renders_and_writes_what_comes_back(tmp_path):
    from gmcpt.gan.weights import load_generator

    tiny_dataset(tmp_path / "data" / "tiny")
    out = tmp_path / "out"
    # 15 s of training at most: with 6 s, a machine busy with other work finished no step, so no curves came back
    result = _run("--dry-run", OUT=str(out), DEVICE_CHECK_DATA=str(tmp_path / "data"), DEVICE_CHECK_MINUTES="0.25")
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert {p.name for p in out.iterdir()} == RESULTS   # at most 8 files come back from a device call
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ok"] and summary["dry_run"] and summary["environment"]["torch_cuda"] is False
    assert set(summary["stages"]) == {"entry-points", "environment", "cuda-tests", "demo", "train"}
    assert summary["training"]["stopped_early"] and summary["training"]["steps"] > 0
    assert summary["demo"]["device"] == "cpu"
    generator, metadata = load_generator(out / "gan-gpu-device.pt")
    assert metadata["dataset"]["path"] == str(tmp_path / "data" / "tiny") and metadata["config"]["train"]["steps"] == 60000
    log = (out / "device-check.log").read_text()
    assert "skipped" in log and "cuda-tests: exit 0" in log and "train: exit 0" in log


def test_bad_usage_is_one_line_and_status_2(tmp_path):
    for args, env, message in ((["--fast"], {"OUT": str(tmp_path)}, "unknown argument --fast"),
                               ([], {"OUT": ""}, "set OUT")):
        result = _run(*args, **env)
        assert result.returncode == 2 and result.stderr.count("\n") == 1 and message in result.stderr
    assert not any(tmp_path.iterdir())


def test_pack_shares_the_budget_between_datasets_and_keeps_their_validation(tmp_path):
    spec = importlib.util.spec_from_file_location("pack_device", ROOT / "scripts" / "pack_device.py")
    pack = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(pack)
    for name, count in (("a", 3), ("b", 2)):
        tiny_dataset(tmp_path / name, count=count)
    example = (tmp_path / "a" / "train" / "0000000.npz").stat().st_size
    out = tmp_path / "packed"
    packed = pack.pack_datasets([tmp_path / "a", tmp_path / "b"], out, budget=int(example * 5.5), val=1)
    assert [(p["packed"], p["train"], p["val"]) for p in packed] == [("a", 2, 1), ("b", 1, 1)]
    assert pack.folder_bytes(out) <= example * 5.5 and (out / "a" / "manifest.json").is_file()
