import numpy as np
import pytest
from scipy import ndimage

from gmcpt.errors import GmcptError
from gmcpt.sampling.masks import (FEATURE_PATTERNS, PATTERNS, _kth_smallest, make_mask, mask_rng, sample_by_density,
                         second_pass_mask)
from gmcpt.sampling.placement import error_density, feature_density


def edge_density(height, width):
    """The feature density of a frame with one vertical albedo edge and a brighter-than-average square."""
    albedo = np.full((height, width, 3), 0.5, np.float32)
    albedo[:, width // 2:] = 0.1
    normal = np.zeros((height, width, 3), np.float32)
    normal[..., 2] = 1
    return feature_density(albedo, normal, np.full((height, width), 0.5, np.float32),
                           np.ones((height, width), np.float32))


def mask_of(pattern, height, width, rate, seed):
    density = edge_density(height, width) if pattern in FEATURE_PATTERNS else None
    return make_mask(height, width, rate, pattern, seed, density)


@pytest.mark.parametrize("pattern", PATTERNS)
@pytest.mark.parametrize("rate", [0.05, 0.3, 0.77, 1.0])
def test_exact_count_and_determinism(pattern, rate):
    mask = mask_of(pattern, 37, 53, rate, seed=4)
    assert mask.shape == (37, 53) and mask.dtype == bool
    assert mask.sum() == round(rate * 37 * 53)
    assert np.array_equal(mask, mask_of(pattern, 37, 53, rate, seed=4))


@pytest.mark.parametrize("pattern", PATTERNS)
def test_seed_changes_mask(pattern):
    assert not np.array_equal(mask_of(pattern, 64, 64, 0.3, 0), mask_of(pattern, 64, 64, 0.3, 1))


def test_adaptive_mask_follows_the_density():
    density = edge_density(128, 128)
    mask = make_mask(128, 128, 0.2, "adaptive", 0, density)
    near_edge = density > 1.5
    assert near_edge.any() and mask[near_edge].mean() > 2 * mask[~near_edge].mean()


@pytest.mark.parametrize("height, width", [(37, 53), (64, 64)])
def test_feature_density_marks_the_edge_at_any_size(height, width):
    # the edges are found on 2x2 bins; an odd frame's last row and column are bins of their own
    density = edge_density(height, width)
    assert density.shape == (height, width) and density.dtype == np.float32
    assert np.isclose(density.mean(), 1.0, atol=1e-4) and np.isfinite(density).all()
    columns = np.arange(width)
    near, far = np.abs(columns - width // 2) <= 3, np.abs(columns - width // 2) >= 8
    assert density[:, near].min() > 2 * density[:, far].max()


def test_floor_leaves_no_empty_tile_on_a_flat_scene():
    # a flat scene but for one edge: at rate 0.2 every 16x16 tile still gets samples
    mask = make_mask(256, 256, 0.2, "adaptive", 3, edge_density(256, 256))
    tiles = mask.reshape(16, 16, 16, 16).sum(axis=(1, 3))
    assert tiles.min() > 0.2 * 256 * 0.3


@pytest.mark.parametrize("seed", [0, 7])
def test_two_passes_over_an_even_density_are_one_blue_noise_set(seed):
    # the second pass draws on the first pass's threshold map: together they are the one-pass draw of the
    # whole count (one threshold tile, so no keys tie), not two independent sets that clump
    even = np.ones((128, 96), np.float32)
    first = sample_by_density(even, 1000, mask_rng(seed))
    both = first | second_pass_mask(even, 1500, first, seed)
    assert both.sum() == 2500 and np.array_equal(both, sample_by_density(even, 2500, mask_rng(seed)))


def test_density_sampling_skips_excluded_pixels_and_clips_the_count():
    density = np.ones((20, 30), np.float32)
    exclude = np.zeros((20, 30), bool)
    exclude[:, :10] = True
    mask = sample_by_density(density, 150, mask_rng(1), exclude=exclude)
    assert mask.sum() == 150 and not (mask & exclude).any()
    assert sample_by_density(density, 10_000, mask_rng(1), exclude=exclude).sum() == 400


@pytest.mark.parametrize("count", [1, 999, 1000, 1001, 4095, 4096])
def test_density_sampling_is_exact_where_keys_tie(count):
    # a flat density over a frame of four threshold tiles: every key appears four times, so the
    # count-th smallest is tied with others at most counts
    density = np.ones((256, 256), np.float32)
    mask = sample_by_density(density, count, mask_rng(5))
    assert mask.sum() == count
    assert np.array_equal(mask, sample_by_density(density, count, mask_rng(5)))


@pytest.mark.parametrize("size", [1, 7, 300, 65536])
@pytest.mark.parametrize("levels", [0, 3, 50])
def test_bracketed_selection_equals_a_full_partition(size, levels):
    # continuous keys, keys of a few levels (ties everywhere) and a spike of equal keys mid-range
    rng = np.random.default_rng(size + levels)
    keys = rng.standard_normal(size).astype(np.float32)
    if levels:
        keys = np.round(keys * levels) / levels
    keys[: size // 3] = np.float32(0.25)
    for k in sorted({0, size // 10, size // 2, size - 1, *rng.integers(0, size, 8).tolist()}):
        assert _kth_smallest(keys, k) == np.partition(keys, k)[k]


@pytest.mark.parametrize("pattern", FEATURE_PATTERNS)
def test_feature_patterns_need_a_density(pattern):
    with pytest.raises(GmcptError, match="sampling density"):
        make_mask(8, 8, 0.5, pattern)


@pytest.mark.parametrize("pattern", ["stratified", "blue_noise"])
def test_even_patterns_have_smaller_holes_than_white_noise(pattern):
    def largest_hole(mask):
        return ndimage.distance_transform_edt(~mask).max()
    white = np.mean([largest_hole(make_mask(128, 128, 0.2, "random", s)) for s in range(3)])
    even = np.mean([largest_hole(mask_of(pattern, 128, 128, 0.2, s)) for s in range(3)])
    assert even < 0.8 * white


@pytest.mark.parametrize("rate", [0, -0.1, 1.0001, float("nan"), float("inf"), "abc"])
def test_bad_rate(rate):
    with pytest.raises(GmcptError, match="rate"):
        make_mask(8, 8, rate)


def test_unknown_pattern():
    with pytest.raises(GmcptError, match="unknown mask pattern"):
        make_mask(8, 8, 0.5, "poisson")


def test_error_density_follows_radiance_structure_the_features_do_not_explain():
    # flat features; the radiance has a shadow edge at x = 40 that no feature buffer shows
    height, width = 64, 80
    albedo = np.full((height, width, 3), 0.5, np.float32)
    normal = np.zeros((height, width, 3), np.float32)
    normal[..., 2] = 1
    flat = feature_density(albedo, normal, np.full((height, width), 0.5, np.float32),
                           np.ones((height, width), np.float32), np.ones((height, width), np.float32))
    first = sample_by_density(flat, height * width // 6, mask_rng(2))
    radiance = np.where(np.arange(width)[None, :, None] < 40, 0.05, 1.0) * np.ones((height, width, 3), np.float32)
    variance = np.full((height, width), 1e-6, np.float32)
    density = error_density(np.where(first[..., None], radiance, 0), np.where(first, variance, 0), first,
                            albedo, np.ones((height, width), np.float32), flat)
    assert density.dtype == np.float32 and density.shape == (height, width)
    assert np.isclose(density.mean(), 1.0, atol=1e-4) and (density[first] == 0).all()
    def near_over_far(values):
        untraced = ~first
        near = values[:, 36:44][untraced[:, 36:44]].mean()
        far = np.concatenate([values[:, :24][untraced[:, :24]], values[:, 56:][untraced[:, 56:]]]).mean()
        return near / far

    assert near_over_far(density) > 2
    # a noisy but flat frame: its noise explains the spread, no region is preferred
    rng = np.random.default_rng(0)
    noisy = (0.5 + 0.05 * rng.standard_normal((height, width, 1))) * np.ones(3, np.float32)
    flat_error = error_density(np.where(first[..., None], noisy, 0), np.where(first, 0.05 ** 2, 0), first,
                               albedo, np.ones((height, width), np.float32), flat)
    assert 0.7 < near_over_far(flat_error) < 1.4


def test_the_kept_threshold_map_cannot_be_written():
    """The threshold map of a placement is kept for the next draw on it: a caller cannot change it."""
    from gmcpt.sampling.masks import _thresholds

    thresholds = _thresholds(200, 300, mask_rng(4))
    assert thresholds.shape == (200, 300) and not thresholds.flags.writeable
    with pytest.raises(ValueError):
        thresholds[0, 0] = 0.0
    assert np.array_equal(_thresholds(200, 300, mask_rng(4)), thresholds)
