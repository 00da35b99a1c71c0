"""OIDN's large model for dense frames below budget 16: the denoiser reading, its rule, its price, OIDN's pace."""
import math
import types

import numpy as np
import pytest

from budget_helpers import SIZE, render_budget as _render
from conftest import CORNELL


def test_the_denoiser_proxy_compares_the_large_models_move_with_a_doubling_of_samples():
    from gmcpt.budget import denoiser_proxy

    rng = np.random.default_rng(3)
    half = rng.uniform(0.2, 0.6, (16, 16, 3)).astype(np.float32)
    quarter = half + rng.normal(0, 0.05, half.shape).astype(np.float32)
    assert denoiser_proxy(quarter, half, half) == 0.0
    assert denoiser_proxy(quarter, half, quarter) == pytest.approx(1.0)
    assert denoiser_proxy(quarter, half, half + 2 * (quarter - half)) > 3.5  # twice as far: four times the square


@pytest.mark.parametrize("proxy,extra,frame,pays", [(1.3, 0.1, 0.3, True), (1.0, 0.1, 0.3, False),
                                                    (1.3, 0.2, 0.3, False)])
def test_the_large_model_pays_where_the_scene_reads_high_and_it_costs_under_half_the_frame(proxy, extra, frame, pays):
    from gmcpt.budget import large_model_pays

    assert large_model_pays(proxy, extra, frame) is pays


@pytest.mark.parametrize("remembered,rays", [(2.0, 16), (0.5, 4)])
def test_a_dense_frame_takes_16_ray_guides_where_the_scenes_denoiser_reading_says_so(mi, monkeypatch, remembered, rays):
    from gmcpt import budget
    from gmcpt.costs import frame_costs
    from gmcpt.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense without a probe
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)  # the time never stands in the way
    scene = load_scene(CORNELL, resolution=SIZE)
    first = _render(scene, 4.0)  # learns the path tracer's pace: no reading before it
    assert first.info["guide_spp"] == 4 and "denoiser_proxy" not in first.info
    frame_costs(scene, SIZE[0] * SIZE[1]).denoiser(4).learn(remembered)
    frame = _render(scene, 4.0, seed=1)
    assert frame.info["guide_spp"] == rays and frame.info["denoiser_proxy"] == remembered
    assert frame.info["path_samples"] == 4 * SIZE[0] * SIZE[1]


@pytest.mark.parametrize("samples", [4, 3, 2])
def test_a_dense_frame_without_a_denoiser_reading_splits_its_launch_and_reads_one(mi, monkeypatch, samples):
    from gmcpt import budget
    from gmcpt.costs import frame_costs
    from gmcpt.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)
    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", math.inf)  # even placement: the Cornell box's 4 is one launch
    scene = load_scene(CORNELL, resolution=SIZE)
    _render(scene, samples)
    frame = _render(scene, samples, seed=1)
    reading = frame_costs(scene, SIZE[0] * SIZE[1]).denoiser(samples)
    assert frame.info["denoiser_proxy"] > 0 and reading.value == frame.info["denoiser_proxy"]
    assert frame.info["path_samples"] == samples * SIZE[0] * SIZE[1] and np.isfinite(frame.radiance).all()
    assert frame.info["guide_spp"] == (16 if frame.info["denoiser_proxy"] >= budget.LARGE_MODEL_PROXY_ABOVE else 4)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # too dear: neither read nor taken
    fresh = load_scene(CORNELL, resolution=SIZE)
    _render(fresh, samples)
    frame = _render(fresh, samples, seed=1)
    assert "denoiser_proxy" not in frame.info and frame.info["guide_spp"] == 4


def test_a_frame_of_one_sample_a_pixel_reads_no_denoiser(mi, monkeypatch):
    from gmcpt import budget
    from gmcpt.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)
    scene = load_scene(CORNELL, resolution=SIZE)
    _render(scene, 1.0)
    assert "denoiser_proxy" not in _render(scene, 1.0, seed=1).info  # one launch cannot be split in two


def test_the_large_model_is_priced_with_the_guide_rays_it_adds_and_taken_as_the_scene_reads():
    from gmcpt.budget import BudgetPlan
    from gmcpt.costs import FrameCosts
    from gmcpt.large_model import extra_seconds, large_model_rays

    trace = types.SimpleNamespace(info={}, sums=types.SimpleNamespace(size=64))
    plan = BudgetPlan(budget=4.0, pixels=64, samples=256, sparse_pixels=16)
    # guides of 4 rays at 0.01 s a ray: the 12 rays up to 16 are part of the price
    assert extra_seconds(64, 4, 0.01) - extra_seconds(64, 16, 0.01) == pytest.approx(0.12)
    rays, price = large_model_rays(trace, plan, FrameCosts(64), 4, 0.01, frame_seconds=1.0)
    assert rays == 4 and price == (pytest.approx(extra_seconds(64, 4, 0.01)), 1.0)  # no reading yet: read it
    costs = FrameCosts(64)
    costs.denoiser(4).learn(10.0)  # a reading that pays
    assert large_model_rays(trace, plan, costs, 4, 0.01, 1.0) == (16, None) and trace.info["denoiser_proxy"] == 10.0
    costs.denoiser(4).learn(0.0)
    assert large_model_rays(trace, plan, costs, 4, 0.01, 1.0) == (4, None)
    assert large_model_rays(trace, plan, FrameCosts(64), 4, None, 1.0) == (4, None)  # no pace of a guide ray yet
    assert large_model_rays(trace, plan, FrameCosts(64), 4, 0.01, None) == (4, None)  # nor of the frame


def test_the_denoisers_pace_is_what_this_process_measured_for_each_model(monkeypatch):
    from gmcpt import costs

    monkeypatch.setattr(costs, "_denoise_pace", {"usual": None, "large": None})
    monkeypatch.setattr(costs, "_denoise_runs", {"usual": 0, "large": 0})
    guess = costs.completion_seconds(1000)
    assert guess == pytest.approx(1000 * costs.DENOISE_SECONDS_PER_PIXEL)
    costs.record_denoise(2.0, 1000)  # the first run loads OIDN: not counted
    costs.record_denoise(2.0, 1000, large=True)
    assert costs.completion_seconds(1000) == guess
    costs.record_denoise(0.004, 1000)  # slower than the first guess: the measurement replaces it
    assert costs.completion_seconds(1000) == pytest.approx(0.004)
    assert costs.completion_seconds(1000, large=True) == pytest.approx(0.004 * costs.LARGE_MODEL_TIME_RATIO)
    costs.record_denoise(0.02, 1000, large=True)
    costs.record_denoise(0.03, 1000, large=True)  # the fewest counts: a first run loads the model
    assert costs.completion_seconds(1000, large=True) == pytest.approx(0.02)
    assert costs.completion_seconds(1000) == pytest.approx(0.004)
