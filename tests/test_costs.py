"""The cost model a budget's choice weighs time with: its checks, the machine's stored model, ``--costs``, and the
same bits from the same arguments and model whatever the machine's pace and the frames before."""
import json
import math
import os
import subprocess
import sys
from dataclasses import replace

import pytest

from budget_helpers import SIZE, fixed_costs
from conftest import CORNELL, ROOT


@pytest.mark.parametrize("bad", [0.0, -1e-6, math.nan, math.inf, True, "1e-6", None])
def test_a_cost_model_refuses_anything_but_positive_seconds(bad):
    from gmcpt.errors import GmcptError

    with pytest.raises(GmcptError, match="path") as error:
        fixed_costs(path=bad)
    assert "\n" not in str(error.value)


def test_the_cost_model_prices_a_frames_parts():
    model = fixed_costs()
    dense = 100 * (4 * model.path + 5 * model.guide_ray + model.denoise)
    assert model.dense_seconds(100, 4.0, 5) == pytest.approx(dense)
    assert model.completion_seconds(100, large=True) == pytest.approx(100 * model.denoise_large)
    assert model.large_model_seconds(100, 16, 16) == pytest.approx(100 * (model.denoise_large - model.denoise))


def test_read_costs_takes_a_costs_file_or_a_sidecar_and_refuses_anything_else(tmp_path):
    from gmcpt.sampling.costs import read_costs
    from gmcpt.errors import GmcptError

    model = fixed_costs()
    (tmp_path / "costs.json").write_text(json.dumps({"format": "gmcpt-costs 1", "costs": model.record()}))
    (tmp_path / "frame.json").write_text(json.dumps({"budget_choice": "sparse", "costs": model.record()}))
    assert read_costs(tmp_path / "costs.json") == model == read_costs(tmp_path / "frame.json")
    bad = {"broken.json": "{", "rate.json": json.dumps({"parameters": {"rate": 0.3}}),
           "short.json": json.dumps({"costs": {"path": 1e-6}}),
           "negative.json": json.dumps({"costs": {**model.record(), "denoise": -1.0}})}
    for name, text in bad.items():
        (tmp_path / name).write_text(text)
    for name in [*bad, "missing.json"]:
        with pytest.raises(GmcptError, match="--costs") as error:
            read_costs(tmp_path / name)
        assert "\n" not in str(error.value) and name in str(error.value)


@pytest.fixture
def cache(mi, monkeypatch, tmp_path):
    """A cache folder of the test's own, and measurements counted instead of made: (folder, measurements)."""
    from gmcpt.sampling import costs

    monkeypatch.setenv("GMCPT_CACHE", str(tmp_path / "cache"))
    measured = []
    monkeypatch.setattr(costs, "measure_costs", lambda: measured.append(1) or fixed_costs())
    return tmp_path / "cache", measured


def test_the_machines_model_is_measured_once_and_stored(cache):
    from gmcpt.sampling.costs import COSTS_FORMAT, machine, machine_costs, machine_costs_path

    folder, measured = cache
    said = []
    assert machine_costs(said.append) == fixed_costs() and len(measured) == 1 and len(said) == 1
    stored = json.loads(machine_costs_path().read_text())
    assert machine_costs_path().parent == folder / "costs" and stored["format"] == COSTS_FORMAT
    assert stored["machine"] == machine() and stored["costs"] == fixed_costs().record()
    assert machine_costs() == fixed_costs() and len(measured) == 1  # read, not measured again
    assert sorted(path.name for path in machine_costs_path().parent.iterdir()) == [machine_costs_path().name]


@pytest.mark.parametrize("text", ["{not json", '{"costs": {"path": 1}}', ""])
def test_a_stored_model_that_cannot_be_read_is_measured_again_with_a_one_line_note(cache, capsys, text):
    from gmcpt.sampling.costs import machine_costs, machine_costs_path

    _, measured = cache
    machine_costs_path().parent.mkdir(parents=True)
    machine_costs_path().write_text(text)
    assert machine_costs() == fixed_costs() and len(measured) == 1
    error = capsys.readouterr().err
    assert error.startswith("note: ") and error.count("\n") == 1 and "Traceback" not in error
    assert json.loads(machine_costs_path().read_text())["costs"] == fixed_costs().record()


def test_a_frame_without_a_model_weighs_with_the_machines_and_its_choice_follows_it(cache):
    """No model given: the machine's stored one, recorded with the frame. Where every signal would choose sparse, a
    machine whose sparse way is cheap goes sparse, and one whose sparse way is dear goes dense."""
    from gmcpt.sampling import budget
    from gmcpt.sampling.costs import machine_costs_path
    from gmcpt.render.scene import load_scene
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    with pytest.MonkeyPatch.context() as patch:
        for name in ("DENSE_ABOVE", "EDGES_ABOVE"):
            patch.setattr(budget, name, math.inf)
        choices = []
        for model in (fixed_costs(sparse_extra=1e-9), fixed_costs(sparse_extra=1e-3)):
            machine_costs_path().parent.mkdir(parents=True, exist_ok=True)
            machine_costs_path().write_text(json.dumps({"costs": model.record()}))
            scene = load_scene(CORNELL, resolution=SIZE)
            frame, _ = render_sparse_frame(scene, scene.integrator().integrator, settings=RenderSettings(budget=4.8))
            assert frame.info.costs == model.record()
            choices.append(frame.info.budget_choice)
    assert choices == ["sparse", "dense"] and not cache[1]  # nothing measured: the stored model was read


def test_the_machines_model_is_measured_on_its_own_scene(mi):
    from gmcpt.sampling.costs import measure_costs

    model = measure_costs(side=32)
    assert all(0 < value < 1e-3 for value in model.record().values())  # seconds a pixel
    assert model.denoise_large > model.denoise


def test_the_plugin_takes_a_costs_file_and_refuses_a_bad_one(mi, tmp_path):
    costs = tmp_path / "costs.json"
    costs.write_text(json.dumps({"costs": fixed_costs().record()}))
    integrator = mi.load_dict({"type": "masked_path", "budget": 4.8, "costs": str(costs), "completion": "interp"})
    assert integrator.settings().costs == fixed_costs() and integrator.plugin_properties()["costs"] == str(costs)
    costs.write_text("{}")
    with pytest.raises(Exception, match="no cost model"):
        mi.load_dict({"type": "masked_path", "budget": 4.8, "costs": str(costs)})
    with pytest.raises(Exception, match="costs"):  # a sequence makes no budget choice
        mi.load_dict({"type": "masked_path", "budget": 4.8, "history": 2, "costs": str(tmp_path / "x.json")})


def _gmcpt(*args, cache):
    """``python -m gmcpt ARGS`` with ``cache`` as its ``$GMCPT_CACHE``; the CompletedProcess (text)."""
    env = {**os.environ, "PYTHONWARNINGS": "ignore", "GMCPT_CACHE": str(cache), "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "gmcpt", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=600)


def _store_machine_costs(mi, monkeypatch, cache, model) -> None:
    from gmcpt.sampling.costs import machine_costs_path

    monkeypatch.setenv("GMCPT_CACHE", str(cache))
    machine_costs_path().parent.mkdir(parents=True, exist_ok=True)
    machine_costs_path().write_text(json.dumps({"costs": model.record()}))


def test_the_same_arguments_and_costs_give_the_same_bits_in_any_process_at_any_pace(mi, monkeypatch, tmp_path):
    """``gmcpt render`` with the same arguments and ``--costs`` writes the same EXR, to the byte: in two fresh
    processes; on a machine whose own model is three times slower; after other frames of the scene in the same
    process (a batch whose frame comes last); and replaying the model from the first render's sidecar."""
    costs = tmp_path / "costs.json"
    costs.write_text(json.dumps({"costs": fixed_costs().record()}))
    fast, slow = tmp_path / "fast", tmp_path / "slow"
    machine = fixed_costs(sparse_extra=1e-3)  # on its own, this machine's model would choose dense
    _store_machine_costs(mi, monkeypatch, fast, machine)
    _store_machine_costs(mi, monkeypatch, slow, replace(machine, **{name: 3 * value for name, value in
                                                                    machine.record().items()}))
    options = [CORNELL, "--res", *SIZE, "--budget", "4.8", "--method", "interp", "-D", "seed=0", "-q"]
    outs = [tmp_path / name for name in ("one.exr", "two.exr", "three.exr")]
    for out, cache, model in zip(outs, (fast, fast, slow), (costs, costs, outs[0].with_suffix(".json"))):
        result = _gmcpt("render", *options, "--costs", model, "--out", out, cache=cache)
        assert result.returncode == 0, result.stderr
    record = json.loads(outs[0].with_suffix(".json").read_text())
    assert record["costs"] == fixed_costs().record() and record["budget_choice"] == "sparse"
    result = _gmcpt("batch", CORNELL, "--res", *SIZE, "--budget", "4.8", "--method", "interp", "--sweep",
                    "seed=2,1,0", "--costs", costs, "--out", tmp_path / "batch", "-q", cache=slow)
    assert result.returncode == 0, result.stderr
    last = tmp_path / "batch" / "cornell-box_seed-0000.exr"
    for out in [*outs[1:], last]:
        assert out.read_bytes() == outs[0].read_bytes(), out
    without = tmp_path / "machine.exr"  # no --costs: the machine's own model, recorded, and its own choice
    result = _gmcpt("render", *options, "--out", without, cache=fast)
    assert result.returncode == 0, result.stderr
    record = json.loads(without.with_suffix(".json").read_text())
    assert record["costs"] == machine.record() and record["budget_choice"] == "dense"


def test_cli_refuses_a_costs_file_without_a_model_in_one_line(tmp_path):
    (tmp_path / "x.json").write_text(json.dumps({"parameters": {}}))
    result = _gmcpt("render", CORNELL, "--budget", "4.8", "--costs", tmp_path / "x.json", "--out",
                    tmp_path / "out.exr", cache=tmp_path / "cache")
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and "--costs" in result.stderr
    assert not (tmp_path / "out.exr").exists()
