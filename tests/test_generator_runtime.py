"""The generator's network on OpenVINO: the same output as PyTorch, converted once, rebuilt when damaged,
run without torch once converted, and PyTorch when the runtime is missing."""
import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT, synthetic_frame
from gmcpt.gan import export, runtime
from gmcpt.gan.infer import precomplete
from gmcpt.gan.weights import load_generator, weights_path

needs_openvino = pytest.mark.skipif(importlib.util.find_spec("openvino") is None, reason="OpenVINO is not installed")


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """No compiled network or warning left from another test; the cache in ``tmp_path``."""
    monkeypatch.setenv("GMCPT_CACHE", str(tmp_path))
    monkeypatch.delenv(runtime.RUNTIME_ENV, raising=False)
    runtime._cached_network.cache_clear()
    runtime.warn_once.cache_clear()
    yield
    runtime._cached_network.cache_clear()


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    """A cache folder holding the shipped weights' network, converted once for the module."""
    cache = tmp_path_factory.mktemp("cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("GMCPT_CACHE", str(cache))
        export.export(load_generator()[0], runtime.model_path(weights_path()))
    return cache


@pytest.fixture
def cache(converted, fresh, monkeypatch):
    monkeypatch.setenv("GMCPT_CACHE", str(converted))
    return converted


def counting_exports(monkeypatch) -> list:
    calls = []
    real = export.export
    monkeypatch.setattr(export, "export", lambda *args: (calls.append(args), real(*args)))
    return calls


@needs_openvino
def test_openvino_matches_pytorch_and_repeats_itself(cache):
    generator, _ = load_generator()
    frame, _ = synthetic_frame(64, 72)
    network = runtime.compile_network(weights_path(), "float32", 2)
    exact, factor = precomplete(generator, frame, threads=2)
    first, same_factor = precomplete(generator, frame, threads=2, network=network)
    second, _ = precomplete(generator, frame, threads=2, network=network)
    assert np.array_equal(first, second) and np.array_equal(factor, same_factor)
    assert float(np.abs(first - exact).max()) < 1e-3 and float(exact.std()) > 1.0   # on 0..255


@needs_openvino
def test_a_converted_network_is_read_back_not_converted_again(cache, monkeypatch):
    calls = counting_exports(monkeypatch)
    assert runtime.compile_network(weights_path(), "float32", 1) is not None
    assert calls == []


@needs_openvino
@pytest.mark.parametrize("damage", [".bin", ".json"])  # a damaged .xml fails to compile as a .bin does
def test_a_damaged_cached_network_is_converted_again(cache, monkeypatch, damage):
    path = runtime.model_path(weights_path())
    path.with_suffix(damage).write_bytes(b"not a network")
    older = path.with_name(f"{weights_path().stem}-{'0' * 16}-{'0' * 8}-ov1.bin")   # weights since replaced
    older.write_bytes(b"")
    calls = counting_exports(monkeypatch)
    generator, _ = load_generator()
    frame, _ = synthetic_frame(32, 32)
    network = runtime.compile_network(weights_path(), "float32", 1)
    assert len(calls) == 1 and path.stat().st_size > 1000 and not older.exists()
    output, _ = precomplete(generator, frame, network=network)
    assert np.isfinite(output).all()


def test_without_openvino_the_generator_runs_in_pytorch_after_one_line(fresh, monkeypatch, capsys):
    from gmcpt.completion.learned import generator_fill

    monkeypatch.setitem(sys.modules, "openvino", None)  # import openvino: ImportError
    frame, _ = synthetic_frame(32, 32)
    assert runtime.cpu_network(weights_path(), "float32", 1) is None
    working, _, _ = generator_fill(frame)
    assert np.isfinite(working).all()
    err = capsys.readouterr().err
    assert err.startswith("warning: ") and err.count("\n") == 1 and "not installed" in err


def test_the_runtime_setting(fresh, monkeypatch):
    from gmcpt.errors import BadValue

    monkeypatch.setenv(runtime.RUNTIME_ENV, "torch")
    assert runtime.cpu_network(weights_path(), "float32", 1) is None
    monkeypatch.setenv(runtime.RUNTIME_ENV, "onnx")
    with pytest.raises(BadValue, match="generator runtime 'onnx'"):
        runtime.wanted_runtime()


@needs_openvino
def test_a_converted_network_completes_a_frame_without_torch(cache):
    """A process whose network is on disk runs the generator, OpenVINO alone: torch is never imported (6-7 s)."""
    script = (f"import sys; sys.path.insert(0, {str(ROOT / 'tests')!r})\n"
              "from conftest import synthetic_frame\n"
              "from gmcpt.completion import complete\n"
              "result = complete(synthetic_frame(40, 48)[0], 'gan')\n"
              "assert result.image.std() > 0 and 'load_weights_s' in result.timings\n"
              "print('torch' in sys.modules)")
    env = {**os.environ, "GMCPT_CACHE": str(cache)}
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False"]
