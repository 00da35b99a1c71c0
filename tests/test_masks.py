import numpy as np
import pytest
from scipy import ndimage

from gmcpt.errors import GmcptError
from gmcpt.masks import PATTERNS, make_mask


@pytest.mark.parametrize("pattern", PATTERNS)
@pytest.mark.parametrize("rate", [0.05, 0.3, 0.77, 1.0])
def test_exact_count_and_determinism(pattern, rate):
    mask = make_mask(37, 53, rate, pattern, seed=4)
    assert mask.shape == (37, 53) and mask.dtype == bool
    assert mask.sum() == round(rate * 37 * 53)
    assert np.array_equal(mask, make_mask(37, 53, rate, pattern, seed=4))


@pytest.mark.parametrize("pattern", PATTERNS)
def test_seed_changes_mask(pattern):
    assert not np.array_equal(make_mask(64, 64, 0.3, pattern, 0), make_mask(64, 64, 0.3, pattern, 1))


@pytest.mark.parametrize("pattern", ["stratified", "blue_noise"])
def test_even_patterns_have_smaller_holes_than_white_noise(pattern):
    def largest_hole(mask):
        return ndimage.distance_transform_edt(~mask).max()
    white = np.mean([largest_hole(make_mask(128, 128, 0.2, "random", s)) for s in range(3)])
    even = np.mean([largest_hole(make_mask(128, 128, 0.2, pattern, s)) for s in range(3)])
    assert even < 0.8 * white


@pytest.mark.parametrize("rate", [0, -0.1, 1.0001, float("nan"), float("inf"), "abc"])
def test_bad_rate(rate):
    with pytest.raises(GmcptError, match="rate"):
        make_mask(8, 8, rate)


def test_unknown_pattern():
    with pytest.raises(GmcptError, match="unknown mask pattern"):
        make_mask(8, 8, 0.5, "poisson")
