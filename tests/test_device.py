"""Where completion's torch stages run: gmcpt.device, and the generator on another device."""
import numpy as np
import pytest
import torch

from conftest import run_cli, CORNELL


def test_auto_is_cuda_exactly_where_torch_sees_a_gpu(monkeypatch):
    from gmcpt.device import completion_device

    monkeypatch.delenv("GMCPT_DEVICE", raising=False)
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert completion_device() == completion_device("auto") == expected
    assert completion_device("cpu") == "cpu"
    monkeypatch.setenv("GMCPT_DEVICE", "cpu")
    assert completion_device() == "cpu"


@pytest.mark.parametrize("wanted", ["tpu", "meta", "cuda:x"])
def test_a_device_that_is_not_cpu_or_cuda_is_refused(wanted):
    from gmcpt.device import completion_device
    from gmcpt.errors import BadValue

    with pytest.raises(BadValue, match="device"):
        completion_device(wanted)


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is present")
def test_cuda_without_a_gpu_is_an_error_not_a_silent_cpu_run():
    from gmcpt.device import completion_device
    from gmcpt.errors import BadValue

    with pytest.raises(BadValue, match="no CUDA device"):
        completion_device("cuda")


def test_low_rank_params_keep_auto_until_they_run():
    from dataclasses import replace

    from gmcpt.lowrank.params import DEFAULT

    assert DEFAULT.device == "auto"
    assert replace(DEFAULT, device="cpu").device == "cpu"
    with pytest.raises(ValueError, match="not a torch device"):
        replace(DEFAULT, device="nonsense")


def test_cli_refuses_an_unknown_device_before_rendering(tmp_path, monkeypatch):
    monkeypatch.setenv("GMCPT_DEVICE", "tpu")
    out = tmp_path / "out.exr"
    result = run_cli(CORNELL, "--out", out, "--res", "32", "24", "--spp", "2", "--method", "pawnnm")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "device 'tpu'" in result.stderr
    assert "features" not in result.stdout + result.stderr and not out.exists()


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_generator_on_cuda_matches_the_cpu(monkeypatch):
    from conftest import synthetic_frame
    from gmcpt.completion import complete

    frame, _ = synthetic_frame(96, 128)
    monkeypatch.setenv("GMCPT_DEVICE", "cpu")
    on_cpu = complete(frame, "gan_pawnnm").image
    monkeypatch.setenv("GMCPT_DEVICE", "cuda")
    on_gpu = complete(frame, "gan_pawnnm").image
    assert np.abs(on_cpu - on_gpu).mean() < 1e-3 * np.abs(on_cpu).mean()
