"""The generator's network on OpenVINO: the same output as PyTorch, converted once, rebuilt when damaged,
run without torch once converted, and PyTorch when the runtime is missing; its compiled network cached on disk:
written once and read back, the same image, rebuilt when damaged, and no error where it cannot be written."""
import hashlib
import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

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
def cache(converted, fresh, monkeypatch, tmp_path):
    """A copy of the module's cache folder, this test's own to damage or add compiled networks to."""
    own = shutil.copytree(converted, tmp_path / "cache")
    monkeypatch.setenv("GMCPT_CACHE", str(own))
    return own


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
    """A process whose network is on disk runs the generator, OpenVINO alone: torch is never imported (6-7 s),
    nor OpenVINO's conversion tools."""
    script = (f"import sys; sys.path.insert(0, {str(ROOT / 'tests')!r})\n"
              "from conftest import synthetic_frame\n"
              "from gmcpt.completion import complete\n"
              "result = complete(synthetic_frame(40, 48)[0], 'gan')\n"
              "assert result.image.std() > 0 and 'load_weights_s' in result.timings\n"
              "print('torch' in sys.modules, 'openvino.tools.ovc' in sys.modules)")
    env = {**os.environ, "GMCPT_CACHE": str(cache)}
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "False"]


def counting_compiles(monkeypatch) -> list:
    """The converted networks compiled from their IR (not read back compiled) while the test runs."""
    calls = []
    real = runtime._compiled
    monkeypatch.setattr(runtime, "_compiled", lambda *args: (calls.append(args), real(*args))[1])
    return calls


def compiled_entry() -> Path:
    return runtime.compiled_path(runtime.model_path(weights_path()),
                                 {"INFERENCE_PRECISION_HINT": "f32", "PERFORMANCE_HINT": "LATENCY",
                                  "INFERENCE_NUM_THREADS": 1})


@needs_openvino
def test_the_compiled_network_is_cached_once_and_read_back(cache, monkeypatch):
    compiles, exports = counting_compiles(monkeypatch), counting_exports(monkeypatch)
    runtime.compile_network(weights_path(), "float32", 1)
    entry = compiled_entry()
    written = entry.stat().st_mtime_ns
    runtime.compile_network(weights_path(), "float32", 1)
    assert len(compiles) == 1 and exports == [] and entry.stat().st_mtime_ns == written
    assert entry.read_bytes().startswith(runtime.COMPILED_FORMAT)


@needs_openvino
def test_the_image_is_the_same_with_and_without_the_cached_compiled_network(cache, monkeypatch):
    from gmcpt.completion import complete

    compiles = counting_compiles(monkeypatch)
    frame, _ = synthetic_frame(40, 56)
    images = []
    for _ in range(2):  # compiled, then read back in a new lookup
        runtime._cached_network.cache_clear()
        images.append(complete(frame, "gan_oidn").image)
    assert len(compiles) == 1 and np.array_equal(images[0], images[1]) and float(images[0].std()) > 0


@needs_openvino
def test_a_new_compiled_network_removes_those_of_older_conversions_only(cache):
    entry = compiled_entry()
    entry.parent.mkdir(parents=True)
    older = entry.with_name(f"{weights_path().stem}-{'0' * 16}-{'0' * 8}-ov1-{'0' * 12}.blob")  # weights replaced
    other_settings = entry.with_name(entry.stem.rsplit("-", 1)[0] + f"-{'1' * 12}.blob")
    other_weights = entry.with_name(f"g-{'0' * 16}-{'0' * 8}-ov1-{'0' * 12}.blob")
    for path in (older, other_settings, other_weights):
        path.write_bytes(b"")
    runtime.compile_network(weights_path(), "float32", 1)
    assert entry.is_file() and not older.exists() and other_settings.exists() and other_weights.exists()


def damaged(data: bytes, how: str) -> bytes:
    """A compiled entry spoilt as a disk, a killed writer or another program might spoil it."""
    header = data.split(b"\n", 2)[1]
    if how == "flipped":
        return data[:-100] + bytes([data[-100] ^ 1]) + data[-99:]
    if how == "refused":  # a sound record of a payload OpenVINO does not read
        record = {**json.loads(header), "sha256": hashlib.sha256(b"junk").hexdigest()}
        return runtime.COMPILED_FORMAT + json.dumps(record).encode() + b"\n" + b"junk"
    return {"truncated": data[: len(data) // 2], "garbage": b"not a network", "empty": b""}[how]


@needs_openvino
@pytest.mark.parametrize("how", ["truncated", "flipped", "refused", "garbage", "empty"])
def test_a_damaged_compiled_network_is_compiled_again_silently(cache, monkeypatch, capfd, how):
    runtime.compile_network(weights_path(), "float32", 1)
    entry = compiled_entry()
    sound = entry.read_bytes()
    entry.write_bytes(damaged(sound, how))
    compiles = counting_compiles(monkeypatch)
    network = runtime.compile_network(weights_path(), "float32", 1)
    output, _ = precomplete(load_generator()[0], synthetic_frame(32, 32)[0], network=network)
    assert len(compiles) == 1 and np.isfinite(output).all()
    assert runtime.read_compiled(runtime.openvino_module().Core(), entry, {}) is not None
    assert capfd.readouterr().err == ""


@needs_openvino
def test_a_compiled_folder_that_cannot_be_made_caches_nothing_and_says_nothing(cache, capfd):
    (cache / "generators" / "compiled").write_text("a file where the folder would be")
    assert runtime.cpu_network(weights_path(), "float32", 1) is not None
    assert capfd.readouterr().err == ""


@needs_openvino
def test_a_cache_that_cannot_be_written_still_completes(converted, fresh, monkeypatch, tmp_path, capfd):
    """No folder can be made under ``$GMCPT_CACHE``: the network is converted into a temporary folder (here the
    module's conversion copied, not converted again) and the frame completes on OpenVINO, with no message."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("GMCPT_CACHE", str(blocker / "cache"))
    written = []

    def copy_conversion(generator, path):
        for file in (converted / "generators").glob("*"):
            shutil.copy(file, path.with_suffix(file.suffix))
        written.append(path)

    monkeypatch.setattr(export, "export", copy_conversion)
    from gmcpt.completion import complete

    result = complete(synthetic_frame(40, 48)[0], "gan_oidn")
    assert np.isfinite(result.image).all() and len(written) == 1 and not written[0].exists()
    assert runtime.cpu_network(weights_path(), "float32", 1) is not None and capfd.readouterr().err == ""
