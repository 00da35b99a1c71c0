"""Adaptive path tracing + OIDN, the evaluation's strongest baseline: exact sample totals, determinism, bounds."""
import numpy as np
import pytest

from conftest import CORNELL


@pytest.fixture(scope="module")
def cornell(mi):
    from gmcpt.render.scene import load_scene
    return load_scene(CORNELL, resolution=(40, 32))


@pytest.fixture(scope="module")
def path_tracer(mi):
    return mi.load_dict({"type": "path", "max_depth": 8})


@pytest.mark.parametrize("total,cap", [(0, 4), (1, 4), (997, 4), (4000, 4), (2500, 32)])
def test_allocation_is_exact_capped_and_follows_the_weights(total, cap):
    from gmcpt.sampling.adaptive import allocate

    weights = np.random.default_rng(3).gamma(0.5, size=1000)
    weights[:10] = 0.0
    counts = allocate(weights, total, cap)
    assert counts.sum() == total and counts.min() >= 0 and counts.max() <= cap
    if 0 < total < cap * 1000 // 4:
        heavy, light = weights > np.quantile(weights, 0.9), (weights > 0) & (weights < np.quantile(weights, 0.1))
        assert counts[heavy].mean() > counts[light].mean()
        assert counts[:10].sum() == 0  # no error estimate, no extra samples
    np.testing.assert_array_equal(counts, allocate(weights, total, cap))


def test_the_rounding_remainder_goes_to_the_largest_fractions_then_the_lowest_pixels():
    from gmcpt.sampling.adaptive import allocate

    np.testing.assert_array_equal(allocate(np.ones(10), 13, 4), [2, 2, 2, 1, 1, 1, 1, 1, 1, 1])
    # ideal 0.2 / 0.6 / 0.2 / 0.6 / 0.4: the two 0.6s first, then the 0.4
    np.testing.assert_array_equal(allocate(np.float64([1, 3, 1, 3, 2]), 2, 4), [0, 1, 0, 1, 0])
    np.testing.assert_array_equal(allocate(np.float64([1, 3, 1, 3, 2]), 3, 4), [0, 1, 0, 1, 1])


def test_allocation_refuses_more_samples_than_the_cap_allows():
    from gmcpt.sampling.adaptive import allocate
    from gmcpt.errors import GmcptError

    with pytest.raises(GmcptError, match="cannot place"):
        allocate(np.ones(10), 41, 4)


def test_display_error_is_high_where_the_image_is_noisy_and_fireflies_count_as_white():
    from gmcpt.sampling.adaptive import display_error

    rng = np.random.default_rng(0)
    image = np.full((32, 32, 3), 0.3, np.float32)
    image[:, 16:] *= rng.exponential(size=(32, 16, 1)).astype(np.float32)
    error = display_error(image)
    assert error[:, :14].max() < 1e-6 < error[:, 18:].min()
    firefly, white = image.copy(), image.copy()
    firefly[8, 5], white[8, 5] = 1000.0, 1.0
    np.testing.assert_array_equal(display_error(firefly), display_error(white))


@pytest.mark.parametrize("budget", [1.0, 2.5, 4.8])
def test_render_traces_exactly_the_budget_and_repeats_itself(mi, cornell, path_tracer, budget):
    from gmcpt.sampling.adaptive import AdaptiveSettings, render_adaptive

    settings = AdaptiveSettings(budget=budget, seed=5)
    image, info, timings = render_adaptive(cornell, path_tracer, settings)
    assert info.path_samples == round(budget * 40 * 32) == info.samples.sum()
    assert info.samples.min() >= settings.first_spp >= 1
    assert info.samples.max() <= settings.first_spp + settings.max_extra
    assert image.shape == (32, 40, 3) and np.isfinite(image).all() and image.mean() > 0.01
    assert {"features_s", "render_s", "placement_s", "denoise_s"} <= timings.keys()
    again, info_again, _ = render_adaptive(cornell, path_tracer, settings)
    np.testing.assert_array_equal(image, again)
    np.testing.assert_array_equal(info.samples, info_again.samples)


def test_more_samples_land_where_the_first_pass_is_noisy(mi, cornell, path_tracer):
    """The Cornell box's light and the shadows under the boxes are noisier than its lit walls: the extra
    samples must not be spread evenly."""
    from gmcpt.sampling.adaptive import AdaptiveSettings, render_adaptive

    settings = AdaptiveSettings(budget=6.0, seed=1)
    _, info, _ = render_adaptive(cornell, path_tracer, settings)
    extra = info.samples - settings.first_spp
    assert extra.max() >= 3 * np.median(extra) and np.percentile(extra, 90) >= 2 * np.percentile(extra, 10) + 2


def test_the_first_pass_takes_its_share_of_the_budget():
    from gmcpt.sampling.adaptive import AdaptiveSettings

    assert [AdaptiveSettings(budget=b).first_spp for b in (1, 1.5, 3.2, 4.8, 6.4, 32)] == [1, 1, 2, 3, 4, 20]
    assert AdaptiveSettings(budget=4.8, first_share=0).first_spp == 1


@pytest.mark.parametrize("options,message", [
    ({"budget": 0.5}, "budget must be in"), ({"budget": 65.0}, "budget must be in"),
    ({"budget": float("nan")}, "budget must be in"), ({"budget": 4, "seed": -1}, "seed"),
    ({"budget": 4, "exponent": -1}, "exponent"), ({"budget": 4, "max_extra": 0}, "max_extra"),
    ({"budget": 4, "first_share": 1.5}, "first_share"), ({"budget": 40, "first_share": 0}, "more than max_extra")])
def test_bad_settings_get_one_line(options, message):
    from gmcpt.sampling.adaptive import AdaptiveSettings
    from gmcpt.errors import GmcptError

    with pytest.raises(GmcptError, match=message) as error:
        AdaptiveSettings(**options)
    assert "\n" not in str(error.value)
