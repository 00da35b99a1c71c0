"""OIDN's large model for dense frames below budget 16: the denoiser reading, its rule, its price."""
import math
import types

import numpy as np
import pytest

from budget_helpers import SIZE, render_budget as _render
from conftest import CORNELL


def test_the_denoiser_proxy_compares_the_large_models_move_with_a_doubling_of_samples():
    from gmcpt.sampling.budget import denoiser_proxy

    rng = np.random.default_rng(3)
    half = rng.uniform(0.2, 0.6, (16, 16, 3)).astype(np.float32)
    quarter = half + rng.normal(0, 0.05, half.shape).astype(np.float32)
    assert denoiser_proxy(quarter, half, half) == 0.0
    assert denoiser_proxy(quarter, half, quarter) == pytest.approx(1.0)
    assert denoiser_proxy(quarter, half, half + 2 * (quarter - half)) > 3.5  # twice as far: four times the square


@pytest.mark.parametrize("proxy,extra,frame,pays", [(1.3, 0.1, 0.3, True), (1.0, 0.1, 0.3, False),
                                                    (1.3, 0.2, 0.3, False)])
def test_the_large_model_pays_where_the_scene_reads_high_and_it_costs_under_half_the_frame(proxy, extra, frame, pays):
    from gmcpt.sampling.budget import large_model_pays

    assert large_model_pays(proxy, extra, frame) is pays


@pytest.mark.parametrize("above,rays", [(0.0, 16), (math.inf, 4)])
def test_a_dense_frame_reads_what_the_large_model_buys_and_takes_16_ray_guides_where_it_pays(mi, monkeypatch, above,
                                                                                            rays):
    """A frame's reading serves that frame alone: the first frame of a scene reads, and so does the next."""
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)  # dense without a probe
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)  # the time never stands in the way
    monkeypatch.setattr(budget, "LARGE_MODEL_PROXY_ABOVE", above)
    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", math.inf)  # even placement
    scene = load_scene(CORNELL, resolution=SIZE)
    for seed in (0, 1):
        frame = _render(scene, 3.0, seed=seed)  # below 3.2: one even launch, split to read
        assert frame.info.guide_spp == rays and frame.info.denoiser_proxy > 0
        assert frame.info.path_samples == 3 * SIZE[0] * SIZE[1] and np.isfinite(frame.radiance).all()


@pytest.mark.parametrize("samples", [3, 2])
def test_a_dense_frame_that_reads_splits_its_launch(mi, monkeypatch, samples):
    from budget_helpers import record_launches
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)
    scene = load_scene(CORNELL, resolution=SIZE)
    launches = record_launches(monkeypatch)
    frame = _render(scene, samples)
    assert launches == [1, 1, samples - 2][:2 + (samples > 2)] and frame.info.denoiser_proxy > 0
    assert frame.info.path_samples == samples * SIZE[0] * SIZE[1]
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", 0.0)  # too dear: neither read nor taken
    launches.clear()
    frame = _render(scene, samples)
    assert launches == [samples] and frame.info.denoiser_proxy is None and frame.info.guide_spp == 4


@pytest.mark.parametrize("reliable_above,launches,reads", [(math.inf, [1, 1, 2], True), (-1.0, [1, 1], False)])
def test_a_first_pass_read_twice_serves_the_denoiser_reading_where_the_rest_is_even(mi, monkeypatch, reliable_above,
                                                                                    launches, reads):
    """A noisy frame from 3.2 to 4.8 traces its first pass as two launches of 1 spp: where the rest goes evenly the
    first is the large model's reading's quarter and both its half, with no launch more; where it goes adaptively
    nothing is read."""
    from budget_helpers import record_launches
    from gmcpt.sampling import budget, strategies
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)
    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", 0.0)
    monkeypatch.setattr(budget, "RELIABLE_ABOVE", reliable_above)
    monkeypatch.setattr(strategies, "relative_variance", lambda *args: 1.0)  # noisy
    scene = load_scene(CORNELL, resolution=SIZE)
    traced = record_launches(monkeypatch)
    frame = _render(scene, 4.0)
    assert traced == launches and frame.info.error_reliability is not None
    assert frame.info.dense_placement == ("even" if reads else "adaptive")
    assert (frame.info.denoiser_proxy is not None) is reads and frame.info.path_samples == 4 * SIZE[0] * SIZE[1]


def test_a_frame_of_one_sample_a_pixel_or_with_a_first_pass_reads_no_denoiser(mi, monkeypatch):
    from gmcpt.sampling import budget
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "EDGES_ABOVE", -1.0)
    monkeypatch.setattr(budget, "LARGE_MODEL_SHARE_BELOW", math.inf)
    scene = load_scene(CORNELL, resolution=SIZE)
    assert _render(scene, 1.0).info.denoiser_proxy is None  # one launch cannot be split in two
    assert _render(scene, 8.0).info.denoiser_proxy is None  # nor a first pass that reads the error's concentration


def test_the_large_model_is_priced_with_its_guide_rays_and_the_reading_it_needs():
    from budget_helpers import fixed_costs
    from gmcpt.sampling.budget import LARGE_MODEL_SHARE_BELOW, BudgetPlan
    from gmcpt.sampling.large_model import large_model_rays

    plan = BudgetPlan(budget=4.0, pixels=64, samples=256, sparse_pixels=16)
    frame = lambda **costs: types.SimpleNamespace(info={}, costs=fixed_costs(**costs))  # noqa: E731
    model = fixed_costs()
    # guides of 4 rays: the 12 rays up to 16 are part of the price
    assert model.large_model_seconds(64, 4, 16) - model.large_model_seconds(64, 16, 16) == pytest.approx(
        64 * 12 * model.guide_ray)
    cheap = dict(denoise=1e-9, denoise_large=2e-9, guide_ray=1e-9)
    rays, price = large_model_rays(frame(**cheap), plan, 4, noise=1.0)
    assert rays == 4 and price == (pytest.approx(fixed_costs(**cheap).large_model_seconds(64, 4, 16)),
                                   pytest.approx(fixed_costs(**cheap).dense_seconds(64, 4.0, 4)))
    # the reading's three OIDN runs count: a model whose large model alone would cost under half the frame, not with
    # them (a pixel: 0.5 extra against a frame of 4.5, and 2.0 for the reading)
    dear = dict(path=1e-6, denoise=0.5e-6, denoise_large=1e-6, guide_ray=1e-15)
    extra, seconds = fixed_costs(**dear).large_model_seconds(64, 4, 16), fixed_costs(**dear).dense_seconds(64, 4.0, 4)
    assert extra < LARGE_MODEL_SHARE_BELOW * seconds
    assert large_model_rays(frame(**dear), plan, 4, noise=1.0) == (4, None)
    assert large_model_rays(frame(**cheap), plan, 4, noise=0.0) == (4, None)  # quiet at 4: an adaptive first pass
    assert large_model_rays(frame(**cheap), plan, 16, noise=1.0) == (16, None)  # clean guides already
