"""Bad input (issue 26, causes 1-8 and 13): one line, exit 2, nothing written, and the same GmcptError from the API.

Each test names its cause. Renders are 16x16 at 1 spp with the quick ``interp`` completion.
"""
import json
import shutil

import numpy as np
import pytest

from conftest import CORNELL, ROOT, STILL_LIFE
from gmcpt.errors import GmcptError
from reliability_helpers import assert_refused, run_plain, snapshot

TINY = ("--res", "16", "16", "--spp", "1", "--method", "interp", "-q")
NO_SENSOR = """<scene version="3.0.0">
  <integrator type="path"/>
  <shape type="sphere"><bsdf type="diffuse"/></shape>
  <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
</scene>"""
SENSOR = """<scene version="3.0.0">
  <sensor type="perspective">
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
    {film}
  </sensor>
</scene>"""


def _refuses(tmp_path, arguments, message, out=None):
    """The command line refuses ``arguments`` with ``message``; nothing in ``tmp_path`` changes."""
    before = snapshot(tmp_path)
    result = run_plain(*arguments, "--out", out or tmp_path / "out.exr")
    line = assert_refused(result, message)
    assert snapshot(tmp_path) == before
    return line


def _api_message(call) -> str:
    with pytest.raises(GmcptError) as error:
        call()
    return str(error.value)


# 1. seeds
@pytest.mark.parametrize("seed", ["-1", "4294967296"])
def test_seed_outside_32_bits_is_refused(tmp_path, seed):
    line = _refuses(tmp_path, [CORNELL, *TINY, "--seed", seed], f"--seed must be in [0, 4294967295]")
    assert line.endswith(f"got {seed}")


def test_api_seed_is_checked_where_the_settings_are_made(mi):
    from gmcpt.sampling.strategies import RenderSettings
    from gmcpt.render.scene import load_scene

    message = _api_message(lambda: RenderSettings(seed=-5))
    assert message == "seed must be in [0, 4294967295] (the samplers take 32-bit seeds), got -5"
    assert message in _api_message(lambda: load_scene(CORNELL, (16, 16), {"seed": "-5"}))  # masked_path's seed


def test_multi_pass_render_and_largest_seed_do_not_overflow(mi, monkeypatch):
    """More lanes than one launch takes: per-pass seeds stay 32-bit for every seed; one pass keeps the seed."""
    from gmcpt.render import kernels
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import load_scene

    assert kernels.pass_seed(123, 0, 1) == 123
    assert all(0 <= kernels.pass_seed(2**32 - 1, index, 7) < 2**32 for index in range(7))
    assert len({kernels.pass_seed(9, index, 4) for index in range(4)}) == 4
    monkeypatch.setattr(kernels, "MAX_LANES", 64)  # 16x16 at rate 0.5 and 4 spp: 512 lanes, 8 passes
    scene = load_scene(CORNELL, (16, 16))
    frame, _ = render_sparse_frame(scene, mi.load_dict({"type": "path"}),
                                   settings=RenderSettings(rate=0.5, spp=4, seed=2**32 - 1))
    assert frame.mask.sum() == 128 and np.isfinite(frame.radiance).all() and frame.radiance.max() > 0


# 2. samples per pixel
@pytest.mark.parametrize("option, limit", [("--spp", 65536), ("--feature-spp", 1024)])
def test_absurd_sample_counts_are_refused_at_once(tmp_path, option, limit):
    arguments = [CORNELL, "--res", "16", "16", "--method", "interp", "-q", option, "1000000000"]
    _refuses(tmp_path, arguments, f"{option} must be at most {limit} (")


def test_api_sample_counts(mi):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import load_scene

    assert _api_message(lambda: RenderSettings(spp=10**9)).startswith("spp must be at most 65536 (")
    assert _api_message(lambda: RenderSettings(feature_spp=10**9)).startswith("feature_spp must be at most 1024 (")
    scene = load_scene(CORNELL, (16, 16), {"spp": str(10**9)})  # the scene's own sampler asks for it
    message = _api_message(lambda: render_sparse_frame(scene, mi.load_dict({"type": "path"})))
    assert message.startswith("spp must be at most 65536 (")


# 3. resolution
@pytest.mark.parametrize("arguments", [("--res", "100000", "100000"), ("-D", "res=100000")],
                         ids=["--res", "scene film"])
def test_resolution_beyond_memory_is_refused_with_what_it_needs(tmp_path, arguments):
    line = _refuses(tmp_path, [CORNELL, "--spp", "1", "--method", "interp", *arguments],
                    "image 100000x100000 needs about 9.3 TiB of memory")
    assert "is available; lower the resolution" in line


def test_api_resolution(mi):
    from gmcpt.sampling.strategies import render_sparse_frame
    from gmcpt.render.scene import load_scene

    scene = load_scene(CORNELL, (100000, 100000))
    message = _api_message(lambda: render_sparse_frame(scene, mi.load_dict({"type": "path"})))
    assert message.startswith("image 100000x100000 needs about 9.3 TiB of memory")


# 4. a scene without a sensor
@pytest.mark.parametrize("resolution", [(), ("--res", "16", "16")], ids=["scene size", "--res"])
def test_scene_without_sensor(tmp_path, resolution):
    scene = tmp_path / "nosensor.xml"
    scene.write_text(NO_SENSOR)
    _refuses(tmp_path, [scene, "--method", "interp", *resolution], f"scene {scene} has no <sensor>")


def test_api_scene_without_sensor(mi, tmp_path):
    from gmcpt.sampling.strategies import render_sparse_frame
    from gmcpt.render.scene import load_scene

    (tmp_path / "nosensor.xml").write_text(NO_SENSOR)
    assert "has no <sensor>" in _api_message(lambda: load_scene(tmp_path / "nosensor.xml"))
    bare = mi.load_dict({"type": "scene", "shape": {"type": "sphere"}})
    assert "has no <sensor>" in _api_message(lambda: render_sparse_frame(bare, mi.load_dict({"type": "path"})))


# 5. a sensor in an included file
@pytest.mark.parametrize("film", ['<film type="hdrfilm"><integer name="width" value="40"/></film>', ""],
                         ids=["film", "default film"])
def test_sensor_in_an_included_file_is_found(mi, tmp_path, film):
    from gmcpt.io.exr import read_rgb_exr
    from gmcpt.render.scene import load_scene

    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "camera.xml").write_text(SENSOR.format(film=film))
    scene = tmp_path / "scene.xml"
    scene.write_text(NO_SENSOR.replace("<integrator", '<include filename="parts/camera.xml"/>\n  <integrator'))
    result = run_plain(scene, *TINY, "--res", "24", "16", "--out", tmp_path / "out.exr")
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert read_rgb_exr(tmp_path / "out.exr").shape == (16, 24, 3)
    assert tuple(load_scene(scene, (20, 12)).sensors()[0].film().crop_size()) == (20, 12)


# 6. a malformed record beside a weights file
@pytest.mark.parametrize("record, problem", [('{"sha256": ', "is not readable JSON"), ("[1, 2]", "is not a JSON object")])
def test_malformed_weights_record(tmp_path, record, problem):
    from gmcpt.gan.weights import load_generator

    weights = tmp_path / "w.pt"
    shutil.copy(ROOT / "gmcpt" / "gan" / "weights" / "gan-cpu.pt", weights)
    (tmp_path / "w.json").write_text(record)
    line = _refuses(tmp_path, [CORNELL, "--res", "16", "16", "--weights", weights], f"GAN weights {tmp_path / 'w.json'} {problem}")
    assert _api_message(lambda: load_generator(weights)) == line


# 7. a reference with NaN/Inf, and JSON that is always valid
def test_reference_with_nan_or_inf_is_refused(tmp_path):
    from gmcpt.io.exr import write_exr
    from gmcpt.image.metrics import all_metrics

    image = np.ones((16, 16), np.float32)
    bad = image.copy()
    bad[3, 3], bad[4, 4] = np.nan, np.inf
    write_exr(tmp_path / "ref.exr", {"R": bad, "G": image, "B": image})
    line = _refuses(tmp_path, [CORNELL, *TINY, "--reference", tmp_path / "ref.exr"], "has 2 NaN/Inf values")
    reference = np.stack([bad, image, image], axis=-1)
    assert line.endswith(_api_message(lambda: all_metrics(np.ones((16, 16, 3), np.float32), reference)))


def _strict_json(text: str) -> dict:
    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")
    return json.loads(text, parse_constant=refuse)


def test_json_record_is_strict_json_when_a_metric_is_infinite(tmp_path):
    first, second = tmp_path / "first.exr", tmp_path / "second.exr"
    assert run_plain(CORNELL, *TINY, "--out", first).returncode == 0
    result = run_plain(CORNELL, *TINY, "--reference", first, "--out", second)  # the same image: PSNR is infinite
    assert result.returncode == 0, result.stderr
    metrics = _strict_json(second.with_suffix(".json").read_text())["metrics"]
    assert metrics["mse"] == 0 and metrics["psnr"] is None


# 8. an output that is an input
def _collision_cases(tmp_path):
    from gmcpt.io.exr import write_exr

    reference = tmp_path / "ref.exr"
    write_exr(reference, {c: np.ones((16, 16), np.float32) for c in "RGB"})
    named_json = tmp_path / "kernels.json"  # a scene whose name is the output's JSON sidecar
    shutil.copy(CORNELL, named_json)
    still_life = tmp_path / "still-life"
    shutil.copytree(STILL_LIFE.parent, still_life)
    weights = tmp_path / "w.pt"
    shutil.copy(ROOT / "gmcpt" / "gan" / "weights" / "gan-cpu.pt", weights)
    shutil.copy(ROOT / "gmcpt" / "gan" / "weights" / "gan-cpu.json", tmp_path / "w.json")
    return {"reference": ([CORNELL, "--reference", reference], reference, "the reference"),
            "scene": ([named_json], tmp_path / "kernels.exr", "the scene file"),
            "texture": ([still_life / "scene.xml"], still_life / "wood.exr", "the scene file"),
            "weights record": ([CORNELL, "--method", "gan", "--weights", weights], tmp_path / "w.exr",
                               "the weights record")}


@pytest.mark.parametrize("case", ["reference", "scene", "texture", "weights record"])
def test_output_that_would_overwrite_an_input_is_refused(tmp_path, case):
    arguments, out, what = _collision_cases(tmp_path)[case]
    line = _refuses(tmp_path, [*arguments, "--res", "16", "16", "--spp", "1", "-q"], "would overwrite " + what, out)
    assert line.endswith("choose another --out")


# 13. nothing on stderr beside the error
def test_bad_scene_parameter_is_one_line_without_the_plugin_traceback(mi, tmp_path):
    from gmcpt.render.scene import load_scene

    line = _refuses(tmp_path, [CORNELL, *TINY, "-D", "rate=2"], "rate must be in (0, 1], got 2.0")
    assert line == _api_message(lambda: load_scene(CORNELL, (16, 16), {"rate": "2"}))
    assert line == f"cannot load scene {CORNELL}: rate must be in (0, 1], got 2.0"


def test_truncated_reference_is_one_line(tmp_path, capfd):
    from gmcpt.io.exr import read_exr, write_exr

    whole = tmp_path / "whole.exr"
    write_exr(whole, {c: np.random.default_rng(0).random((16, 16), np.float32) for c in "RGB"})
    (tmp_path / "ref.exr").write_bytes(whole.read_bytes()[:-64])
    whole.unlink()
    line = _refuses(tmp_path, [CORNELL, *TINY, "--reference", tmp_path / "ref.exr"], "cannot read EXR")
    capfd.readouterr()
    assert _api_message(lambda: read_exr(tmp_path / "ref.exr")) == line
    assert capfd.readouterr() == ("", "")  # the library's own lines are not printed


def test_weights_that_torch_warns_about_are_one_line(tmp_path):
    import pickle
    import warnings

    from gmcpt.gan.weights import load_generator

    weights = tmp_path / "w.pt"
    weights.write_bytes(pickle.dumps({"format": 1}, protocol=4))  # torch warns, then refuses it
    _refuses(tmp_path, [CORNELL, "--res", "16", "16", "--weights", weights], "are corrupt or incompatible")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        _api_message(lambda: load_generator(weights))
    assert caught == []


def test_api_functions_raise_gmcpt_error_where_they_raised_value_error():
    from gmcpt.evaluation.scenes import by_name
    from gmcpt.io.exr import unpack
    from gmcpt.image.metrics import mse

    for call in (lambda: unpack(np.zeros((4, 4, 3))), lambda: mse(np.zeros((4, 4, 3)), np.zeros((4, 5, 3))),
                 lambda: by_name(["kitchen"])):
        with pytest.raises(GmcptError) as error:
            call()
        assert isinstance(error.value, ValueError)  # as before, for callers that catch that
