"""A time budget (``--time``, ``time`` on masked_path, ``RenderSettings.time``): every pixel traced, in passes
sized to fill the seconds; bad values get one line."""
import json

import numpy as np
import pytest

from budget_helpers import fixed_costs
from conftest import CORNELL, run_cli

SIZE = (40, 32)


@pytest.fixture(scope="module")
def cornell(mi):
    from gmcpt.render.scene import load_scene
    return load_scene(CORNELL, resolution=SIZE)


def _render(scene, seconds, costs=None):
    from gmcpt.pipeline import render_and_complete
    from gmcpt.sampling.strategies import RenderSettings

    integrator = scene.integrator()
    return render_and_complete(scene, getattr(integrator, "integrator", integrator),
                               RenderSettings(time=seconds, costs=costs or fixed_costs()), "interp")


def test_more_seconds_buy_more_samples_every_pixel_alike(cornell):
    _render(cornell, 0.05)  # compiles the kernels
    short, long = _render(cornell, 0.05), _render(cornell, 1.5)
    for rendered in (short, long):
        info = rendered.frame.info
        assert info.budget_choice == "dense" and rendered.frame.mask.all() and info.time_budget > 0
        assert info.path_samples == info.budget * SIZE[0] * SIZE[1]  # the same samples in every pixel
        assert np.isfinite(rendered.image).all()
    assert long.frame.info.budget > 4 * short.frame.info.budget
    assert long.frame.info.time_spent <= 1.5 * 1.5


def test_a_time_budgets_passes_are_powers_of_two_that_add_up_to_its_samples(cornell, monkeypatch):
    """Each pass size is a recording of the frozen kernel: powers of two keep a scene to a few of them."""
    from budget_helpers import record_launches
    from gmcpt.sampling import strategies

    sizes = record_launches(monkeypatch)
    rendered = _render(cornell, 0.5)
    assert len(sizes) > 1 and all(size & (size - 1) == 0 for size in sizes)
    assert sum(sizes) == rendered.frame.info.budget
    assert [strategies._pass_size(n) for n in (0, 1, 3, 39, 64)] == [0, 1, 2, 32, 64]


@pytest.mark.parametrize("samples_left, expected", [(0.4, 0), (0.6, 1), (1.4, 1), (1.6, 2), (3.6, 4)])
def test_a_time_budgets_next_pass_is_the_nearest_whole_sample(monkeypatch, samples_left, expected):
    """Rounded, not floored: a short budget ends within half a sample of its seconds instead of up to one short."""
    from types import SimpleNamespace

    from gmcpt.sampling import strategies

    monkeypatch.setattr(strategies.time, "perf_counter", lambda: 10.0)
    trace = SimpleNamespace(sums=SimpleNamespace(size=100, samples=100), started=10.0, twin=None,
                            costs=fixed_costs(denoise=1e-15, denoise_large=1e-15))
    assert strategies._next_pass(trace, samples_left * 0.05, 0.05) == (expected, pytest.approx(samples_left * 0.05))


def test_a_time_budgets_guides_come_from_its_samples_first_hits(mi, cornell):
    """As many guide rays as path samples where the integrator has a twin, and no guide pass; a guide pass where
    it has none (``direct``)."""
    from gmcpt.pipeline import render_and_complete
    from gmcpt.sampling.strategies import RenderSettings

    info = _render(cornell, 0.3).frame.info
    assert info.guides == "render" and info.guide_spp == info.budget >= 4
    direct = mi.load_dict({"type": "direct"})
    for _ in range(2):  # the first compiles its kernels
        info = render_and_complete(cornell, direct, RenderSettings(time=0.3, costs=fixed_costs()), "interp").frame.info
    assert info.guides == "pass" and info.guide_spp < info.budget


def test_a_time_budget_traces_every_pass_size_through_one_compiled_kernel(mi, cornell, monkeypatch):
    """``mi.render`` compiles a kernel for each spp, inside the frame: a time budget never calls it, at any size."""
    from gmcpt.render import kernels

    calls, plain = [], mi.render
    monkeypatch.setattr(kernels, "FROZEN_FRAME_SAMPLES", 0)
    monkeypatch.setattr(mi, "render", lambda *args, **kwargs: calls.append(kwargs["spp"]) or plain(*args, **kwargs))
    assert _render(cornell, 0.3).frame.info.budget > 1 and calls == []
    kernels.render_native(cornell, cornell.sensors()[0], cornell.integrator().integrator, 2, 0)
    assert calls == [2]


def test_a_time_below_one_frame_says_so_and_renders_one_sample(cornell):
    rendered = _render(cornell, 1e-4)
    assert rendered.frame.info.time_short and rendered.frame.info.budget == 1
    assert rendered.frame.info.guides == "render" and rendered.frame.info.guide_spp >= 1


@pytest.mark.parametrize("value", ["0", "-1", "nan", "abc", "1e9"])
def test_bad_times_get_one_line(tmp_path, value):
    result = run_cli(CORNELL, "--time", value, "--out", tmp_path / "x.exr", "-q")
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1
    assert "--time" in result.stderr and not (tmp_path / "x.exr").exists()


def test_time_refuses_a_budget_or_an_spp_beside_it(mi, tmp_path):
    from gmcpt.errors import GmcptError
    from gmcpt.sampling.strategies import RenderSettings

    with pytest.raises(GmcptError, match="not both"):
        RenderSettings(time=1.0, budget=4.8)
    for extra in (["--budget", "4"], ["--spp", "4"], ["--rate", "0.3"]):
        result = run_cli(CORNELL, "--time", "1", *extra, "--out", tmp_path / "x.exr", "-q")
        assert result.returncode == 2 and "not both" in result.stderr
    with pytest.raises(Exception, match="time"):
        mi.load_dict({"type": "masked_path", "time": -2.0})


def test_cli_records_the_time_and_the_samples_it_spent(tmp_path):
    out = tmp_path / "timed.exr"
    assert run_cli(CORNELL, "--res", *SIZE, "--time", "2", "--method", "interp", "--out", out, "-q").returncode == 0
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["time"] == 2 and record["parameters"]["budget"] is None
    assert record["spent_budget"] >= 1 and record["time_spent"] > 0 and record["budget_choice"] == "dense"
    # no generator ran, so the process never loaded torch (5-6 s here: pyoidn and the weights' record did)
    assert "weights" not in record["parameters"] and record["parameters"]["device"] == "cpu"


def test_a_time_budget_keeps_back_the_cost_models_seconds_for_oidn(cornell):
    """The completion's seconds, kept back from the passes, are the cost model's estimate of OIDN on this machine: a
    model whose OIDN takes the whole budget leaves one sample a pixel, and the sidecar's model says so."""
    slow = fixed_costs(denoise=10.0 / (SIZE[0] * SIZE[1]), denoise_large=20.0 / (SIZE[0] * SIZE[1]))
    rendered = _render(cornell, 1.0, slow)
    assert rendered.frame.info.time_short and rendered.frame.info.budget == 1
    assert rendered.frame.info.costs == slow.record()
