"""A sample budget instead of a rate: the plan, the chooser's signal and choice, exact totals, the front doors."""
import json
import math

import numpy as np
import pytest

from budget_helpers import SIZE, fixed_costs, record_launches, render_budget as _render
from conftest import CORNELL, run_cli


@pytest.mark.parametrize("bad", [0, -1, math.nan, math.inf, 4097, "lots", None])
def test_bad_budgets_get_one_line(bad):
    from gmcpt.sampling.budget import check_budget
    from gmcpt.errors import GmcptError

    with pytest.raises(GmcptError) as error:
        check_budget(bad)
    assert "\n" not in str(error.value) and "budget" in str(error.value)


def test_plan_counts_the_samples_and_the_sparse_pixels():
    from gmcpt.sampling.budget import SPARSE_SPP, plan_budget
    from gmcpt.errors import GmcptError

    plan = plan_budget(4.8, 1000)
    assert plan.samples == 4800 and plan.sparse_pixels == 4800 // SPARSE_SPP and not plan.dense_only
    assert plan.sparse_rate == pytest.approx(0.3)
    assert plan_budget(16, 1000).dense_only and plan_budget(40, 1000).sparse_pixels == 1000
    # a sample for every pixel but no probe beside it: dense at once; below one a pixel: sparse
    assert plan_budget(1.0, 1000).dense_only and plan_budget(1.03, 1000).dense_only
    assert plan_budget(1.0, 1000).first_pass_pixels == 31  # 62 sparse pixels, half of them first
    assert plan_budget(4.8, 1000).probe_pixels == 10 and plan_budget(0.2, 1000).probe_pixels == 6  # 1%, or the first pass
    assert not plan_budget(0.99, 1000).dense_only and not plan_budget(1.2, 1000).dense_only
    with pytest.raises(GmcptError, match="less than one pixel"):
        plan_budget(0.01, 100)


def test_relative_variance_is_the_median_over_lit_pixels_scaled_to_16_spp():
    from gmcpt.sampling.budget import relative_variance

    mean = np.array([[1.0, 1.0, 1.0], [2.0, 2.0, 2.0], [0.5, 0.5, 0.5], [0.0, 0.0, 0.0]])
    variance = np.array([0.1, 0.8, 0.5, 7.0])  # relative 0.1, 0.2, 2.0; the black pixel is left out
    assert relative_variance(mean, variance) == pytest.approx(0.2)
    assert relative_variance(mean, variance, samples=4) == pytest.approx(0.05)  # a 4-spp mean is 4x as noisy
    assert relative_variance(np.zeros((3, 3)), np.ones(3)) == 0.0


def test_choice_follows_either_signal_and_needs_a_sample_for_every_pixel():
    from gmcpt.sampling.budget import DENSE, DENSE_ABOVE, EDGES_ABOVE, SPARSE, choose, edges_above, plan_budget

    plan = plan_budget(4.8, 1000)
    quiet, flat = DENSE_ABOVE / 2, edges_above(1000) / 2
    assert choose(plan, DENSE_ABOVE * 2, flat) == DENSE
    assert choose(plan, quiet, min(1.0, edges_above(1000) * 1.2)) == DENSE
    # the edge share of a scene falls as its frame grows: so does its threshold, from the 256x256 one
    assert edges_above(256 * 256) == pytest.approx(EDGES_ABOVE)
    assert edges_above(1920 * 1080) < edges_above(960 * 540) < EDGES_ABOVE < edges_above(1000)
    assert choose(plan_budget(4.8, 1920 * 1080), quiet, 0.19) == DENSE  # sponza at 1920x1080
    assert choose(plan_budget(4.8, 256 * 256), quiet, 0.19) == SPARSE
    assert choose(plan, quiet, flat) == SPARSE
    # 4.8 on 1000 pixels: a probe of 10 pixels at 4 spp leaves 4760 samples for a dense frame of 1000
    assert plan.probe_pixels == 10 and plan.dense_after_probe
    assert not plan_budget(1.03, 1000).dense_after_probe  # 1030 - 10 * 4 samples for 1000 pixels
    assert choose(plan_budget(0.9, 1000), DENSE_ABOVE * 2, 1.0) == SPARSE
    assert choose(plan_budget(1.03, 1000), 0.0, 0.0) == DENSE  # dense only: no probe to choose by
    assert choose(plan_budget(20, 1000), 0.0, 0.0) == DENSE
    assert choose(plan, quiet, flat, pays=False) == DENSE  # the sparse way's extra seconds buy more as samples


def test_the_sparse_way_pays_when_its_extra_time_is_worth_less_than_its_gain():
    from gmcpt.sampling.budget import DENSE_GAIN_PER_DOUBLING, SPARSE_GAIN, sparse_pays

    break_even = 2 ** (SPARSE_GAIN / DENSE_GAIN_PER_DOUBLING) - 1  # more samples a pixel, over the budget's
    for budget in (2.0, 8.0):  # the extra seconds buy samples at the path tracer's pace: 0.01 s a sample a pixel
        assert sparse_pays(0.0, 0.01, budget) and sparse_pays(0.9 * break_even * budget * 0.01, 0.01, budget)
        assert not sparse_pays(1.1 * break_even * budget * 0.01, 0.01, budget)
    assert sparse_pays(0.06, 0.03, 8.0) and not sparse_pays(0.06, 0.004, 8.0)  # a cheap scene's samples come cheap


def test_edge_share_counts_the_frame_near_feature_edges():
    from gmcpt.sampling.budget import edge_share

    flat = {"albedo": np.full((32, 32, 3), 0.5, np.float32), "normal": np.zeros((32, 32, 3), np.float32),
            "depth": np.ones((32, 32), np.float32), "visibility": np.ones((32, 32), np.float32)}
    assert edge_share(flat) == 0.0
    striped = dict(flat, albedo=flat["albedo"].copy())
    striped["albedo"][:, ::8] = 0.0  # a dark stripe every 8 columns: edges on both sides of each
    busier = dict(flat, albedo=flat["albedo"].copy())
    busier["albedo"][:, ::4] = 0.0
    assert 0 < edge_share(striped) < edge_share(busier) <= 1


@pytest.mark.parametrize("probe,samples", [(4, 2000), (4, 4096 * 5 - 600 * 4), (4, 4096 * 3), (0, 4096 * 17 + 5)])
def test_even_fill_levels_every_pixel_and_spreads_the_rest(probe, samples):
    from gmcpt.sampling.budget import even_fill

    current = np.zeros((64, 64), np.int64)
    current.ravel()[np.random.default_rng(2).choice(4096, 600, replace=False)] = probe
    more = even_fill(current, samples, seed=3)
    total = current + more
    assert more.min() >= 0 and more.sum() == samples
    level = total[current == 0].min()
    assert total[current == 0].max() <= level + 1  # as even as integers allow
    assert (total[current > 0] >= min(probe, level)).all() and more[current > level].sum() == 0
    np.testing.assert_array_equal(more, even_fill(current, samples, seed=3))
    if 0 < samples % 4096:  # the left-over samples are spread over the frame, not bunched in a corner
        extra = (total > level).reshape(4, 16, 4, 16).sum(axis=(1, 3))
        assert extra.min() > 0 or total.sum() - level * 4096 < 64


@pytest.fixture(scope="module")
def cornell(mi):
    from gmcpt.render.scene import load_scene
    return load_scene(CORNELL, resolution=SIZE)


@pytest.mark.parametrize("threshold,way", [(-1.0, "dense"), (math.inf, "sparse")])
def test_both_ways_spend_the_budget_exactly(cornell, monkeypatch, threshold, way):
    from gmcpt.sampling import budget, strategies
    from gmcpt.sampling.budget import SPARSE_SPP, plan_budget

    monkeypatch.setattr(budget, "DENSE_ABOVE", threshold)
    monkeypatch.setattr(budget, "EDGES_ABOVE", threshold)
    monkeypatch.setattr(budget, "SPARSE_GAIN", threshold)  # the sparse way's time always pays, or never
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # no denoiser reading: its frame splits its launch
    monkeypatch.setattr(strategies, "probes_for_placement", lambda *args: False)  # the placement's own probe: below
    pixels = SIZE[0] * SIZE[1]
    frame = _render(cornell, 4.8)
    plan = plan_budget(4.8, pixels)
    assert frame.info.budget_choice == way
    # dense by the edges and by time: no probe to read; sparse: the probe's pixels begin the first pass
    assert (frame.info.probe, frame.info.relative_variance is None) == (("none", True) if way == "dense"
                                                                             else ("traced", False))
    assert frame.info.edge_share is None if way == "dense" else 0 <= frame.info.edge_share <= 1
    if way == "dense":
        assert frame.info.path_samples == round(4.8 * pixels) and frame.mask.all()
    else:
        assert frame.info.path_samples == plan.sparse_pixels * SPARSE_SPP <= round(4.8 * pixels)
        assert frame.info.traced_pixels == plan.sparse_pixels
        assert frame.info.first_pass_pixels == round(plan.sparse_pixels / 2) == plan.first_pass_pixels
    assert np.isfinite(frame.radiance).all() and (frame.variance[frame.mask] >= 0).all()
    again = _render(cornell, 4.8)
    np.testing.assert_array_equal(frame.radiance, again.radiance)  # same seed, same frame
    assert not np.array_equal(frame.radiance, _render(cornell, 4.8, seed=1).radiance)


def test_the_choice_follows_the_cost_model_from_a_scenes_first_frame(mi, monkeypatch):
    """Time is priced by the cost model alone: where the signals would choose sparse, a model whose sparse way is
    cheap goes sparse in a scene's first frame, and one whose sparse way is dear goes dense without a probe."""
    from gmcpt.sampling import budget, strategies
    from gmcpt.render.scene import load_scene

    for name in ("DENSE_ABOVE", "EDGES_ABOVE"):
        monkeypatch.setattr(budget, name, math.inf)  # the signals choose sparse
    monkeypatch.setattr(strategies, "probes_for_placement", lambda *args: False)
    cheap, dear = fixed_costs(sparse_extra=1e-9), fixed_costs(sparse_extra=1e-3)
    sparse = _render(load_scene(CORNELL, resolution=SIZE), 4.8, costs=cheap)
    assert (sparse.info.budget_choice, sparse.info.probe) == ("sparse", "traced")
    assert sparse.info.costs == cheap.record() and 0 < sparse.info.sparse_time_share < 1e-3
    dense = _render(load_scene(CORNELL, resolution=SIZE), 4.8, costs=dear)
    assert (dense.info.budget_choice, dense.info.probe) == ("dense", "none")
    assert dense.mask.all() and dense.info.path_samples == round(4.8 * SIZE[0] * SIZE[1])


def test_a_frame_is_the_same_whatever_frames_came_before(mi):
    """Nothing a frame reads is kept for the next: a frame after others of the same scene, at other budgets and
    seeds, is the frame a fresh scene gives, its readings included."""
    from gmcpt.render.scene import load_scene

    scene = load_scene(CORNELL, resolution=SIZE)
    first = _render(scene, 4.8)
    for budget, seed in ((2.0, 1), (8.0, 2), (5.0, 3)):
        _render(scene, budget, seed)
    again, fresh = _render(scene, 4.8), _render(load_scene(CORNELL, resolution=SIZE), 4.8)
    for frame in (again, fresh):
        np.testing.assert_array_equal(frame.radiance, first.radiance)
        assert frame.info == first.info


def test_every_frame_reads_its_own_probe(mi, monkeypatch):
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "DENSE_ABOVE", 1e-12)  # the probe reads dense, nothing else does
    monkeypatch.setattr(budget, "EDGES_ABOVE", math.inf)
    monkeypatch.setattr(budget, "SPARSE_GAIN", math.inf)
    scene = load_scene(CORNELL, resolution=SIZE)
    frames = [_render(scene, 4.0) for _ in range(3)]
    assert [frame.info.probe for frame in frames] == ["traced"] * 3
    frame = frames[-1]  # the whole budget in Mitsuba's own render, as even as it gets
    assert frame.info.budget_choice == "dense" and frame.info.path_samples == 4 * SIZE[0] * SIZE[1]
    assert frame.info.relative_variance is not None and frame.mask.all()


def test_a_dense_frame_at_an_integral_budget_is_mitsubas_render_of_its_seed(mi, monkeypatch):
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense without a probe
    scene = load_scene(CORNELL, resolution=SIZE)  # a scene of its own: no earlier probe's reading
    budget_spp = 2  # below ADAPTIVE_FROM_BUDGET: one launch
    frame = _render(scene, float(budget_spp), seed=3)
    native = np.asarray(mi.render(scene, integrator=scene.integrator().integrator, spp=budget_spp, seed=3))[..., :3]
    assert frame.info.probe == "none" and frame.info.path_samples == budget_spp * SIZE[0] * SIZE[1]
    np.testing.assert_allclose(frame.radiance, native, rtol=1e-5, atol=1e-6)


def test_a_budget_of_16_or_more_traces_every_pixel(cornell):
    frame = _render(cornell, 17.5)
    assert frame.info.budget_choice == "dense" and frame.info.relative_variance is None
    assert frame.mask.all() and frame.info.path_samples == round(17.5 * SIZE[0] * SIZE[1])


def test_a_budget_refuses_an_spp_and_other_masks(mi):
    from gmcpt.errors import GmcptError
    from gmcpt.sampling.strategies import RenderSettings

    with pytest.raises(GmcptError, match="not both"):
        RenderSettings(budget=4.8, spp=16)
    with pytest.raises(GmcptError, match="two_pass"):
        RenderSettings(budget=4.8, pattern="random")
    with pytest.raises(Exception, match="two_pass"):  # Mitsuba wraps a plugin's error
        mi.load_dict({"type": "masked_path", "budget": 4.8, "mask": "random"})
    with pytest.raises(Exception, match="budget"):
        mi.load_dict({"type": "masked_path", "budget": -2.0})


def test_the_integrator_renders_a_budget(mi, cornell):
    from gmcpt.errors import GmcptError
    from gmcpt.render.scene import masked_integrator

    integrator = masked_integrator(cornell, budget=4.8, completion="interp")
    image = np.asarray(mi.render(cornell, integrator=integrator))
    assert image.shape[:2] == (SIZE[1], SIZE[0]) and np.isfinite(image).all()
    assert integrator.last_frame.info.path_samples <= round(4.8 * SIZE[0] * SIZE[1])
    with pytest.raises(GmcptError, match="not both"):  # (mi.render wraps the error in its own)
        integrator.render(cornell, spp=8)


def test_cli_a_low_budget_frame_takes_guides_of_4_rays(tmp_path):
    out = tmp_path / "low.exr"
    result = run_cli(CORNELL, "--res", *SIZE, "--budget", "2", "--method", "interp", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["guide_spp"] == 4 and "guide_aliasing" not in record


def test_cli_budget_records_its_choice_and_refuses_a_rate_beside_it(tmp_path):
    out = tmp_path / "budget.exr"
    result = run_cli(CORNELL, "--res", *SIZE, "--budget", "4.8", "--method", "interp", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["budget"] == 4.8 and record["parameters"]["rate"] is None
    assert record["budget_choice"] in ("sparse", "dense") and record["path_samples"] <= round(4.8 * 40 * 32)
    for extra in (["--rate", "0.3"], ["--spp", "8"]):
        result = run_cli(CORNELL, "--budget", "4.8", *extra, "--out", tmp_path / "x.exr", "-q")
        assert result.returncode == 2 and "not both" in result.stderr and len(result.stderr.strip().splitlines()) == 1
    result = run_cli(CORNELL, "--budget", "0", "--out", tmp_path / "x.exr", "-q")
    assert result.returncode == 2 and "--budget" in result.stderr and not (tmp_path / "x.exr").exists()


def test_with_no_rate_no_spp_and_no_budget_the_integrator_spends_the_default_budget(mi, cornell):
    from gmcpt.sampling.masks import DEFAULT_RATE

    pixels = SIZE[0] * SIZE[1]
    spp = cornell.sensors()[0].sampler().sample_count()
    integrator = mi.load_dict({"type": "masked_path", "completion": "interp"})
    assert integrator.rate is None and not integrator.budget
    mi.render(cornell, integrator=integrator)
    info = integrator.last_frame.info
    assert info.budget == pytest.approx(DEFAULT_RATE * spp) and info.budget_choice in ("sparse", "dense")
    assert info.path_samples <= round(DEFAULT_RATE * spp * pixels)
    # an spp given, or a mask other than two_pass: a fixed rate, as before
    integrator.render(cornell, spp=8)
    assert integrator.last_frame.info.budget_choice is None
    assert integrator.last_frame.info.path_samples == round(DEFAULT_RATE * pixels) * 8
    fixed = mi.load_dict({"type": "masked_path", "completion": "interp", "mask": "random"})
    fixed.render(cornell)
    assert fixed.last_frame.info.path_samples == round(DEFAULT_RATE * pixels) * spp


def test_cli_without_a_rate_spends_the_default_budget(tmp_path):
    xml = CORNELL.read_text().replace('<float name="rate" value="$rate"/>', "")
    assert "$rate" not in xml  # the box is built from Mitsuba's shapes alone: it loads from any folder
    scene = tmp_path / "no-rate.xml"
    scene.write_text(xml)
    out = tmp_path / "default.exr"
    result = run_cli(scene, "--res", *SIZE, "--method", "interp", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["budget"] == pytest.approx(0.3 * 16) and record["parameters"]["rate"] is None
    assert record["budget_choice"] in ("sparse", "dense")
    out = tmp_path / "spp.exr"
    result = run_cli(scene, "--res", *SIZE, "--spp", "4", "--method", "interp", "--out", out, "-q")
    assert result.returncode == 0, result.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["parameters"]["rate"] == 0.3 and record["parameters"]["budget"] is None


def test_error_concentration_is_the_share_of_the_noisiest_pixels():
    from gmcpt.sampling.budget import (DENSE_ABOVE, TOP_SHARE, adaptive_first_spp, error_concentration,
                                       probes_for_placement, reads_reliability)

    assert error_concentration(np.ones((40, 50))) == pytest.approx(TOP_SHARE)
    spot = np.zeros((40, 50))
    spot[3, 4] = 2.0
    assert error_concentration(spot) == 1.0 and error_concentration(np.zeros((4, 4))) == 0.0
    ramp = np.arange(2000.0).reshape(40, 50)
    assert TOP_SHARE < error_concentration(ramp) < error_concentration(ramp ** 4) < 1
    assert [adaptive_first_spp(budget) for budget in (3.1, 3.2, 4, 4.8, 8, 16, 100)] == [0, 2, 2, 3, 5, 10, 62]
    quiet, noisy = DENSE_ABOVE / 2, DENSE_ABOVE * 2
    assert not any(reads_reliability(budget, quiet) for budget in (3.1, 3.2, 4.7, 4.8, 8))
    for noise in (noisy, None):  # a noisy scene, or one never probed: from budget 3.2 to 4.8 (a first pass of 2 spp)
        assert [reads_reliability(budget, noise) for budget in (3.1, 3.2, 4.7, 4.8, 8)] == [False, True, True, False,
                                                                                               False]
    assert [probes_for_placement(budget) for budget in (3.1, 3.2, 4.7, 4.8)] == [False, True, True, False]


@pytest.mark.parametrize("threshold,placement", [(0.0, "adaptive"), (math.inf, "even")])
def test_a_dense_frame_from_budget_8_places_its_rest_where_the_error_is(mi, monkeypatch, threshold, placement):
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", threshold)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # no denoiser reading: its frame splits its launch
    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense
    scene = load_scene(CORNELL, resolution=SIZE)  # a scene of its own: no earlier frame's reading
    launches = record_launches(monkeypatch)
    frame = _render(scene, 10.5)
    pixels = SIZE[0] * SIZE[1]
    assert frame.info.budget_choice == "dense" and frame.info.dense_placement == placement
    assert frame.info.path_samples == round(10.5 * pixels) and frame.mask.all()  # the total exact
    assert launches == ([6] if placement == "adaptive" else [6, 4])  # 5/8 of the budget first, then the rest
    launches.clear()
    again = _render(scene, 10.5)  # every frame reads its own concentration: the same seed, the same frame
    np.testing.assert_array_equal(frame.radiance, again.radiance)
    assert launches == ([6] if placement == "adaptive" else [6, 4])


@pytest.mark.parametrize("noise,adaptive_above,reliable_above,launches,placement", [
    (0.01, 0.0, math.inf, [2], "adaptive"),  # quiet: one launch, its concentration alone decides
    (1.0, 0.0, -1.0, [1, 1], "adaptive"),  # noisy: two launches of 1 whose error maps agree well enough
    (1.0, 0.0, math.inf, [1, 1, 2], "even"),  # ... or not: the rest evenly, one launch to the probe's 4 samples
    (1.0, math.inf, -1.0, [1, 1, 2], "even"),  # ... or a concentration that does not pay: their agreement unread
])  # the probe's samples stay in the image: its pixels are left out of the launches, at 4 samples already
def test_below_budget_4_8_a_noisy_scene_reads_its_first_pass_twice(mi, monkeypatch, noise, adaptive_above,
                                                                   reliable_above, launches, placement):
    """Every frame of a budget from 3.2 to 4.8 probes for its placement, dense or not: its own probe says whether it is
    quiet, and a frame that is not places adaptively only where two launches of its first pass agree on where the
    error is; where its concentration alone does not pay, their agreement is not read."""
    from gmcpt.sampling import budget, strategies
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", adaptive_above)
    monkeypatch.setattr(budget, "RELIABLE_ABOVE", reliable_above)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)
    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense by the edges: no probe for the choice
    monkeypatch.setattr(strategies, "relative_variance", lambda *args: noise)  # what the probe reads
    quiet = noise <= budget.DENSE_ABOVE
    scene = load_scene(CORNELL, resolution=SIZE)
    traced = record_launches(monkeypatch)
    readings = []
    for _ in range(2):
        traced.clear()
        frame = _render(scene, 4.0)
        assert traced == launches and frame.info.path_samples == 4 * SIZE[0] * SIZE[1]
        assert frame.info.probe == "traced" and frame.info.budget_choice == "dense"
        assert frame.info.dense_placement == placement
        readings.append(frame.info.error_reliability)
    assert readings[0] == readings[1]  # the same seed, the same reading
    unread = quiet or adaptive_above == math.inf
    assert readings[0] is None if unread else 0.3 < readings[0] <= 1.0  # the Cornell box's edges and light agree
    assert _render(scene, 4.8).info.probe == "none"  # from 4.8 the placement needs no probe


def test_error_reliability_is_the_agreement_of_two_error_maps():
    from gmcpt.sampling.budget import error_reliability

    rng = np.random.default_rng(3)
    edge = np.zeros((40, 50))
    edge[:, 20:23] = 1.0
    first, second = edge + 0.1 * rng.random(edge.shape), edge + 0.1 * rng.random(edge.shape)
    assert error_reliability(first, second) > 0.95  # the error where the scene puts it, in both
    scattered = rng.random((2, 40, 50)) ** 8  # fireflies: wherever each launch's fell
    assert abs(error_reliability(*scattered)) < 0.1
    assert error_reliability(edge, np.ones_like(edge)) == 0.0  # a flat map says nothing


def test_every_frame_reads_its_own_concentration(mi, monkeypatch):
    """The error's concentration grows with the first pass's samples, and a frame weighs none but its own: every
    frame from budget 8 traces its first pass, then the rest."""
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", math.inf)  # every reading says even
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # no denoiser reading
    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense
    scene = load_scene(CORNELL, resolution=SIZE)
    launches = record_launches(monkeypatch)
    for frame_budget in (8, 16, 8, 16):
        _render(scene, frame_budget)
    assert launches == [5, 3, 10, 6] * 2


def test_a_low_budgets_guides_are_4_rays_in_every_frame(mi, monkeypatch):
    """Below budget 4 the guides take 4 rays: a dense frame whose choice read no edges, the render's own first hits
    and a pass of the rays they lack."""
    from gmcpt.sampling import budget, trace
    from gmcpt.render import kernels
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense: no feature top-up
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # no denoiser reading: its guides go to 16 rays
    scene = load_scene(CORNELL, resolution=SIZE)
    passes = []
    means = kernels.feature_means
    monkeypatch.setattr(trace, "feature_means", lambda *args: passes.append(args[2]) or means(*args))
    for _ in range(2):
        passes.clear()
        assert _render(scene, 2).info.guide_spp == 4 and passes == [2]


@pytest.mark.parametrize("budget,feature_spp,rays", [(1, 16, 4), (3.9, 16, 4), (6.4, 16, 6), (64, 16, 16),
                                                      (12, 9, 9), (1, 2, 2)])
def test_guides_take_about_the_budgets_rays_within_their_range(budget, feature_spp, rays):
    from gmcpt.sampling.budget import guide_spp

    assert guide_spp(budget, feature_spp) == rays


@pytest.mark.parametrize("frame_budget,quiet", [(2.0, False), (4.0, False), (4.0, True), (4.8, False), (8.0, False)])
def test_a_dense_frame_keeps_its_probes_samples_and_stays_even(mi, monkeypatch, frame_budget, quiet):
    """The probe's samples stay in a dense frame's image: every sample of the budget is in it, each pixel has as many
    as integers allow (the probe's pixels at least their probe's), and where the probe's count is the level, no
    top-up launch is needed."""
    from gmcpt.render import kernels
    from gmcpt.sampling import budget, dense, strategies
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", math.inf)  # even
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)
    if quiet:  # dense by the edges, probed for the placement alone (budgets 3.2 to 4.8)
        monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
        monkeypatch.setattr(strategies, "relative_variance", lambda *args: 0.0)
    else:  # dense by the probe's reading
        monkeypatch.setattr(budget, "DENSE_ABOVE", 1e-12)
    pixels = SIZE[0] * SIZE[1]
    counts, launches = np.zeros(pixels, np.int64), []
    trace_pixels = kernels.SampleSums.trace

    def traced(self, scene, sensor, integrator, where, spp, seed, say=None):
        counts[where] += spp
        launches.append(where.size)
        return trace_pixels(self, scene, sensor, integrator, where, spp, seed)

    def native(*args):
        counts[:] += args[3]
        return render_native(*args)

    render_native = dense.render_native
    monkeypatch.setattr(kernels.SampleSums, "trace", traced)
    monkeypatch.setattr(dense, "render_native", native)
    in_image = []  # the samples of each pixel the frame's image is the mean of
    buffers = strategies.FrameTrace.buffers
    monkeypatch.setattr(strategies.FrameTrace, "buffers",
                        lambda self: in_image.append(self.sums.finite) or buffers(self))
    # a sparse way that costs next to nothing: only the probe's reading sends the frame dense
    frame = _render(load_scene(CORNELL, resolution=SIZE), frame_budget, costs=fixed_costs(sparse_extra=1e-12))
    assert frame.info.probe == "traced" and frame.info.budget_choice == "dense"
    assert counts.sum() == frame.info.path_samples == round(frame_budget * pixels)
    np.testing.assert_array_equal(in_image[-1], counts)  # none left out of the image
    probe = np.zeros(pixels, bool)
    probe[np.argsort(-counts, kind="stable")[:frame.info.first_pass_pixels]] = True
    others = counts[~probe]
    assert others.max() - others.min() <= 1 and counts[probe].min() >= max(others.max(), budget.PROBE_SPP)
    assert math.floor(frame_budget) - 1 <= others.min() <= frame_budget <= others.max() + 1
    if frame_budget == 4.0:  # the probe's pixels at the level: the probe, then pixel lists of all the others alone
        assert (counts == 4).all() and launches[0] == frame.info.first_pass_pixels
        assert set(launches[1:]) == {pixels - launches[0]}
