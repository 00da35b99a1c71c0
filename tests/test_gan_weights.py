"""GAN weights files, and the completion methods that run them (``gan``, ``gan_pawnnm``)."""
import json

import numpy as np
import pytest
import torch

from gan_helpers import SMALL, generator_inputs
from gmcpt.errors import GmcptError
from gmcpt.gan.model import Generator


def test_weights_round_trip_and_metadata(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights, sha256

    generator = Generator(SMALL)
    torch.nn.init.normal_(generator.tail.weight, std=0.1)
    record = save_weights(tmp_path / "w.pt", generator, {"config": {"x": 1}, "dataset": {"version": 1}})
    assert record["sha256"] == sha256(tmp_path / "w.pt")
    assert json.loads((tmp_path / "w.json").read_text())["dataset"]["version"] == 1
    payload = torch.load(tmp_path / "w.pt", weights_only=True)   # plain tensors and strings only
    stored = [t for t in payload["state_dict"].values() if t.is_floating_point()]
    assert stored and all(t.dtype == torch.float16 for t in stored)
    assert json.loads((tmp_path / "w.json").read_text())["stored_dtype"] == "float16"
    loaded, meta = load_generator(tmp_path / "w.pt")
    assert all(p.dtype == torch.float32 for p in loaded.parameters())
    rounded = Generator(SMALL)   # the generator as stored: its weights rounded to half precision
    rounded.load_state_dict({k: v.half().float() if v.is_floating_point() else v
                             for k, v in generator.state_dict().items()})
    radiance, features = generator_inputs()
    torch.testing.assert_close(loaded(radiance, features), rounded(radiance, features).detach())
    assert meta["config"] == {"x": 1}


def test_weights_too_large_for_half_precision_are_stored_as_they_are(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights

    generator = Generator(SMALL)
    with torch.no_grad():
        generator.tail.weight[0, 0, 0, 0] = 1e6   # beyond float16's range (65504)
    save_weights(tmp_path / "big.pt", generator, {})
    stored = torch.load(tmp_path / "big.pt", weights_only=True)["state_dict"]
    assert stored["tail.weight"].dtype == torch.float32 and stored["tail.bias"].dtype == torch.float16
    loaded, _ = load_generator(tmp_path / "big.pt")
    assert loaded.tail.weight[0, 0, 0, 0].item() == 1e6


def test_a_weights_file_recording_retired_options_loads(tmp_path):
    from gmcpt.gan.retired import RETIRED
    from gmcpt.gan.weights import load_generator, save_weights

    generator = Generator(SMALL)
    torch.nn.init.normal_(generator.tail.weight, std=0.1)
    save_weights(tmp_path / "old.pt", generator, {})
    payload = torch.load(tmp_path / "old.pt", weights_only=True)
    stored = {key: 9 if value is None else value for key, value in RETIRED["generator"].items()}
    payload["generator_config"] = json.dumps({**json.loads(payload["generator_config"]), **stored})
    torch.save(payload, tmp_path / "old.pt")   # as written before those options were retired
    loaded, _ = load_generator(tmp_path / "old.pt", check_hash=False)
    assert loaded.config == SMALL
    radiance, features = generator_inputs()
    assert torch.isfinite(loaded(radiance, features)).all()


def test_missing_or_corrupt_weights_give_one_line_with_the_fix(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights

    with pytest.raises(GmcptError, match="not found.*retrain with `python -m gmcpt train"):
        load_generator(tmp_path / "absent.pt")
    path = tmp_path / "bad.pt"
    save_weights(path, Generator(SMALL), {})
    path.write_bytes(path.read_bytes()[:500])
    for check_hash, pattern in ((True, "sha256"), (False, "corrupt")):
        with pytest.raises(GmcptError, match=pattern) as error:
            load_generator(path, check_hash=check_hash)
        assert "\n" not in str(error.value) and "retrain" in str(error.value)


def test_weights_with_their_record_are_checked_without_torch():
    """A weights file is checked against the sha256 of its record, torch left unimported (6-7 s). (One without a
    record is loaded: test_cli.py's corrupt weights.)"""
    import subprocess
    import sys

    script = ("import sys\nfrom gmcpt.completion import check_weights\n"
              "check_weights('gan', 'gan-cpu')\nprint('torch' in sys.modules)")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False"]


def test_gan_method_with_given_weights(tmp_path):
    from gmcpt.completion import complete
    from gmcpt.gan.weights import save_weights
    from tests.conftest import synthetic_frame

    save_weights(tmp_path / "g.pt", Generator(SMALL), {})
    frame, clean = synthetic_frame(30, 36)   # not a multiple of 8: padded and cropped
    result = complete(frame, "gan", weights=str(tmp_path / "g.pt"))
    assert result.image.shape == (30, 36, 3) and np.isfinite(result.image).all()
    assert "pre_completion_s" in result.timings


def test_target_exposure_sets_the_95th_percentile():
    import dataclasses

    from gmcpt.gan.infer import EXPOSURE_TARGET, exposed, target_exposure
    from tests.conftest import synthetic_frame

    frame, _ = synthetic_frame()
    exposure = target_exposure(frame)
    brought = exposed(frame, exposure)
    level = np.percentile(brought.radiance[brought.mask].mean(axis=-1), 95)
    assert level == pytest.approx(EXPOSURE_TARGET, rel=1e-4)
    assert np.allclose(brought.variance, frame.variance * exposure ** 2)
    assert target_exposure(dataclasses.replace(frame, mask=np.zeros_like(frame.mask))) == 1.0


def test_gan_output_follows_the_exposure_of_its_input(tmp_path, monkeypatch):
    """The target exposure: a frame 7x brighter completes to a 7x brighter image (same network input)."""
    import dataclasses

    from gmcpt.gan.runtime import RUNTIME_ENV

    monkeypatch.setenv(RUNTIME_ENV, "torch")  # the same on either runtime: no conversion of these weights (10 s)

    from gmcpt.completion import complete
    from gmcpt.gan.weights import save_weights
    from tests.conftest import synthetic_frame

    torch.manual_seed(0)
    generator = Generator(SMALL)
    for parameter in generator.parameters():
        torch.nn.init.normal_(parameter, std=0.1)
    save_weights(tmp_path / "g.pt", generator, {})
    frame, _ = synthetic_frame(32, 32)
    frame = dataclasses.replace(frame, variance=np.where(frame.mask, 1e-3, 0).astype(np.float32))
    bright = dataclasses.replace(frame, radiance=frame.radiance * 7, variance=frame.variance * 49)
    image = complete(frame, "gan", weights=str(tmp_path / "g.pt")).image
    np.testing.assert_allclose(complete(bright, "gan", weights=str(tmp_path / "g.pt")).image, 7 * image,
                               rtol=1e-4, atol=1e-6)


def test_shipped_weights_match_their_metadata():
    from gmcpt.gan.weights import DEFAULT_WEIGHTS as name, load_generator, weights_path

    path = weights_path(name)
    generator, meta = load_generator(name)   # checks the sha256
    datasets = meta["dataset"] if isinstance(meta["dataset"], list) else [meta["dataset"]]  # several: a list
    assert meta["command"].startswith("python -m gmcpt train") and all(d["version"] >= 1 for d in datasets)
    assert path.stat().st_size < 5e6


def test_gan_pawnnm_runs_end_to_end():
    from gmcpt.completion import complete
    from gmcpt.gan.weights import DEFAULT_WEIGHTS, weights_path
    from tests.conftest import synthetic_frame

    if not weights_path(DEFAULT_WEIGHTS).is_file():
        pytest.skip("no shipped weights yet")
    frame, clean = synthetic_frame(32, 32)
    result = complete(frame, "gan_pawnnm")
    assert result.image.shape == (32, 32, 3) and np.isfinite(result.image).all()
