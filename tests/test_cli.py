"""render_and_complete.py end to end, and every bad input it must refuse cleanly."""
import json

import numpy as np
import pytest

from conftest import CORNELL, ROOT, run_cli

NAN_SCENE = ROOT / "tests" / "data" / "nan_emitter.xml"
SMALL = ("--res", "32", "24", "--spp", "2")


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    out = tmp_path_factory.mktemp("cli") / "cb.exr"
    result = run_cli(CORNELL, *SMALL, "--rate", "0.4", "--seed", "3", "--out", out)
    assert result.returncode == 0, result.stderr
    return out, result


def test_writes_exr_png_json(rendered):
    from gmcpt.io.exr import channel_names, read_exr

    out, result = rendered
    channels = read_exr(out)
    assert set(channels) == set(channel_names())
    assert channels["R"].shape == (24, 32)
    assert channels["mask.Y"].sum() == round(0.4 * 32 * 24)
    assert out.with_suffix(".png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["rate"] == 0.4 and record["parameters"]["spp"] == 2
    assert record["parameters"]["method"] == "gan_oidn"  # the default: GAN fill, then OIDN
    assert record["parameters"]["weights"] == "gan-cpu" and len(record["parameters"]["weights_sha256"]) == 64
    assert record["parameters"]["generator_precision"] in ("float32", "bfloat16")
    assert record["rendered_fraction"] == pytest.approx(0.4, abs=1e-3)
    assert {"features_s", "mask_s", "render_s", "completion_s", "total_s"} <= record["timings"].keys()
    assert record["parameters"]["mask"] == "two_pass"  # the default placement
    assert record["path_samples"] == round(0.4 * 32 * 24) * 2  # traced pixels x spp, both passes together
    assert record["first_pass_pixels"] == round(round(0.4 * 32 * 24) / 2)
    assert {"mitsuba", "drjit", "torch", "numpy", "gmcpt"} <= record["versions"].keys()
    assert "path tracing" in result.stderr  # progress


def test_same_seed_same_output(rendered, tmp_path):
    """A seed fixes every layer of the output bit for bit, from one process to the next, and a reference equal to
    the image scores a perfect match (against another image's: test_command.py::test_a_reference_serves_render)."""
    from gmcpt.io.exr import read_exr

    out, _ = rendered
    again = tmp_path / "again.exr"
    result = run_cli(CORNELL, *SMALL, "--rate", "0.4", "--seed", "3", "--reference", out, "--out", again, "-q")
    assert result.returncode == 0, result.stderr
    first, second = read_exr(out), read_exr(again)
    assert first.keys() == second.keys() and all(np.array_equal(first[name], second[name]) for name in first)
    metrics = json.loads(again.with_suffix(".json").read_text())["metrics"]
    assert metrics["mse"] == 0 and metrics["relmse"] == 0 and metrics["flip"] == 0 and metrics["ssim"] == pytest.approx(1)


def test_another_seed_another_output(rendered, tmp_path):
    from gmcpt.io.exr import read_exr

    out, _ = rendered
    other = tmp_path / "other.exr"
    assert run_cli(CORNELL, *SMALL, "--rate", "0.4", "--seed", "4", "--out", other, "-q").returncode == 0
    first, third = read_exr(out), read_exr(other)
    assert not np.array_equal(first["mask.Y"], third["mask.Y"]) and not np.array_equal(first["R"], third["R"])


def test_scene_with_plain_path_integrator_is_wrapped(tmp_path):
    out = tmp_path / "nan.exr"
    result = run_cli(NAN_SCENE, "--allow-nonfinite", "--rate", "0.5", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    assert "warning:" in result.stderr and "NaN/Inf" in result.stderr
    from gmcpt.io.exr import read_rgb_exr
    assert np.isfinite(read_rgb_exr(out)).all()
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["nonfinite_samples"] > 0 and "PathIntegrator" in record["parameters"]["integrator"]


def _bad_input_cases(tmp_path):
    malformed = tmp_path / "malformed.xml"
    malformed.write_text('<scene version="3.0.0"><shape type="sphere"')
    unknown_plugin = tmp_path / "unknown.xml"
    unknown_plugin.write_text('<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"/></sensor>'
                              '<shape type="no_such_shape"/></scene>')
    corrupt = tmp_path / "corrupt.exr"
    corrupt.write_bytes(b"not an exr file")
    a_directory = tmp_path / "adir.exr"
    a_directory.mkdir()
    truncated_weights = tmp_path / "truncated.pt"
    truncated_weights.write_bytes((ROOT / "gmcpt" / "gan" / "weights" / "gan-cpu.pt").read_bytes()[:3000])
    return {
        "rate zero": ([CORNELL, "--rate", "0"], "rate must be in (0, 1]"),
        "rate negative": ([CORNELL, "--rate", "-0.5"], "rate must be in (0, 1]"),
        "rate above one": ([CORNELL, "--rate", "1.5"], "rate must be in (0, 1]"),
        "rate nan": ([CORNELL, "--rate", "nan"], "rate must be in (0, 1]"),
        "spp zero": ([CORNELL, "--spp", "0"], "--spp must be >= 1"),
        "spp not a number": ([CORNELL, "--spp", "many"], "invalid int value"),
        "missing scene": ([tmp_path / "nope.xml"], "scene file not found"),
        "malformed scene": ([malformed], "malformed scene XML"),
        "scene Mitsuba rejects": ([unknown_plugin], "cannot load scene"),
        "unknown method": ([CORNELL, "--method", "magic"], "unknown completion method 'magic'"),
        "unknown mask": ([CORNELL, "--mask", "poisson"], "unknown mask pattern 'poisson'"),
        "missing output dir": ([CORNELL], "does not exist", tmp_path / "no" / "such" / "out.exr"),
        "output is a directory": ([CORNELL], "is a directory", a_directory),
        "output not exr": ([CORNELL], "must name an .exr file", tmp_path / "out.png"),
        "corrupt reference": ([CORNELL, "--reference", corrupt], "cannot read EXR"),
        "bad resolution": ([CORNELL, "--res", "0", "10"], "--res must be positive"),
        "image smaller than a patch": ([CORNELL, "--method", "pawnnm", "--res", "5", "5"], "smaller than method"),
        "corrupt weights": ([CORNELL, "--weights", truncated_weights], "are corrupt or incompatible"),
        "missing weights": ([CORNELL, "--weights", tmp_path / "absent.pt"], "GAN weights not found"),
        "weights for a method without": ([CORNELL, "--method", "pawnnm", "--weights", "gan-cpu"], "GAN methods only"),
    }


CASES = ["rate zero", "rate negative", "rate above one", "rate nan", "spp zero", "spp not a number",
         "missing scene", "malformed scene", "scene Mitsuba rejects", "unknown method", "unknown mask",
         "missing output dir", "output is a directory", "output not exr", "corrupt reference", "bad resolution",
         "image smaller than a patch", "corrupt weights", "missing weights", "weights for a method without"]


@pytest.mark.parametrize("case", CASES)
def test_bad_input_one_line_error_no_file(case, tmp_path):
    arguments, message, *target = _bad_input_cases(tmp_path)[case]
    out = target[0] if target else tmp_path / "out.exr"
    before = sorted(p.name for p in tmp_path.rglob("*"))
    result = run_cli(*SMALL, *arguments, "--out", out)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ") and message in lines[0]
    assert "Traceback" not in result.stderr + result.stdout
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, not even temporaries


def test_nonfinite_samples_fail_without_clobbering(tmp_path):
    out = tmp_path / "keep.exr"
    for path in (out, out.with_suffix(".png"), out.with_suffix(".json")):
        path.write_bytes(b"previous result")
    result = run_cli(NAN_SCENE, "--rate", "0.5", "--out", out)
    assert result.returncode == 2
    errors = [line for line in result.stderr.splitlines() if line.startswith("error: ")]
    assert len(errors) == 1 and "NaN/Inf" in errors[0] and result.stderr.strip().endswith(errors[0])
    assert "Traceback" not in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.exr", "keep.json", "keep.png"]
    assert all(p.read_bytes() == b"previous result" for p in tmp_path.iterdir())


def test_reference_of_wrong_size(rendered, tmp_path):
    out, _ = rendered
    result = run_cli(CORNELL, "--res", "16", "16", "--spp", "1", "--reference", out, "--out", tmp_path / "x.exr")
    assert result.returncode == 2 and "reference" in result.stderr and "32x24" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_python_m_gmcpt_is_the_same_cli():
    import subprocess
    import sys
    result = subprocess.run([sys.executable, "-m", "gmcpt", "render", "--help"], capture_output=True, text=True,
                            cwd=ROOT)
    assert result.returncode == 0 and "--rate" in result.stdout and "--method" in result.stdout
    assert result.stdout.startswith("usage: gmcpt render ")


def test_pawnnm_end_to_end_records_substage_timings(tmp_path):
    out = tmp_path / "pawnnm.exr"
    result = run_cli(CORNELL, *SMALL, "--method", "pawnnm", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["method"] == "pawnnm"
    assert {"block_matching_s", "svd_s", "aggregation_s", "pre_completion_s", "completion_s"} <= record["timings"].keys()


@pytest.mark.parametrize("weights", [False, True])
def test_a_bad_command_line_is_refused_before_torch_loads(tmp_path, weights):
    """The checks of a command line's own values need no torch (about 2 s to load) nor scipy's filters (1.3 s):
    bad input is answered at once, also when the command names weights, which load with torch."""
    import subprocess
    import sys

    from gmcpt.gan.names import DEFAULT_WEIGHTS
    code = ("import atexit, sys; atexit.register(lambda: print('loaded:', 'torch' in sys.modules, "
            "'scipy.ndimage' in sys.modules)); from gmcpt.cli import main; sys.exit(main(sys.argv[1:]))")
    result = subprocess.run([sys.executable, "-c", code, "render", str(tmp_path / "missing.xml"), "--out",
                             str(tmp_path / "x.exr"), *(["--weights", DEFAULT_WEIGHTS] if weights else [])],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 2 and "scene file not found" in result.stderr
    assert "loaded: False False" in result.stdout
