"""Where completion's torch stages run: gmcpt.runtime.device, and the generator on another device."""
import numpy as np
import pytest
import torch

from conftest import run_cli, CORNELL


def test_auto_is_cuda_exactly_where_torch_sees_a_gpu(monkeypatch):
    from gmcpt.runtime.device import completion_device

    monkeypatch.delenv("GMCPT_DEVICE", raising=False)
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert completion_device() == completion_device("auto") == expected
    assert completion_device("cpu") == "cpu"
    monkeypatch.setenv("GMCPT_DEVICE", "cpu")
    assert completion_device() == "cpu"


@pytest.mark.parametrize("wanted", ["tpu", "meta", "cuda:x"])
def test_a_device_that_is_not_cpu_or_cuda_is_refused(wanted):
    from gmcpt.runtime.device import completion_device
    from gmcpt.errors import BadValue

    with pytest.raises(BadValue, match="device"):
        completion_device(wanted)


@pytest.mark.skipif(torch.cuda.is_available(), reason="a CUDA device is present")
def test_cuda_without_a_gpu_is_an_error_not_a_silent_cpu_run():
    from gmcpt.runtime.device import completion_device
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


def test_generator_precision_is_bfloat16_only_on_a_cpu_with_native_bfloat16(monkeypatch):
    from gmcpt.runtime.device import generator_precision
    from gmcpt.errors import BadValue

    monkeypatch.delenv("GMCPT_GENERATOR_PRECISION", raising=False)
    native = torch.cpu._is_avx512_bf16_supported() or torch.cpu._is_amx_tile_supported()
    assert generator_precision("cpu") == ("bfloat16" if native else "float32")
    assert generator_precision("cuda") == "float32"
    assert generator_precision("cpu", "float32") == "float32"
    monkeypatch.setenv("GMCPT_GENERATOR_PRECISION", "bfloat16")
    assert generator_precision("cuda") == "bfloat16"
    with pytest.raises(BadValue, match="generator precision 'half'"):
        generator_precision("cpu", "half")


def test_bfloat16_generator_stays_near_float32():
    from gan_helpers import generator_inputs
    from gmcpt.gan.infer import generate
    from gmcpt.gan.weights import load_generator

    generator, _ = load_generator()  # the shipped weights (a fresh network's last layer starts at zero)
    radiance, features = generator_inputs(batch=1, size=64, config=generator.config)
    exact = generate(generator, radiance, features)
    rounded = generate(generator, radiance, features, precision="bfloat16")
    assert rounded.dtype == torch.float32 and rounded.shape == exact.shape
    difference = (rounded - exact).abs().max().item()
    assert 0 < difference < 0.02 * exact.abs().max().item()  # it ran in bfloat16, and stayed close


def test_cli_refuses_an_unknown_generator_precision_before_rendering(tmp_path, monkeypatch):
    monkeypatch.setenv("GMCPT_GENERATOR_PRECISION", "half")
    out = tmp_path / "out.exr"
    result = run_cli(CORNELL, "--out", out, "--res", "32", "24", "--spp", "2")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "generator precision 'half'" in result.stderr
    assert "features" not in result.stdout + result.stderr and not out.exists()


@pytest.mark.cuda
def test_generator_on_cuda_matches_the_cpu(monkeypatch):
    from conftest import synthetic_frame
    from gmcpt.completion import complete

    frame, _ = synthetic_frame(96, 128)
    monkeypatch.setenv("GMCPT_DEVICE", "cpu")
    on_cpu = complete(frame, "gan_pawnnm").image
    monkeypatch.setenv("GMCPT_DEVICE", "cuda")
    on_gpu = complete(frame, "gan_pawnnm").image
    assert np.abs(on_cpu - on_gpu).mean() < 1e-3 * np.abs(on_cpu).mean()
