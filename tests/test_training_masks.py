"""The masks the generator trains on: drawn per crop as the renderer draws them per frame."""
import numpy as np
import pytest

from gmcpt.placement import feature_density


def training_crop(size=64):
    """A crop in the PatchSampler's channel layout (17 channels) with one vertical albedo edge."""
    crop = np.zeros((size, size, 17), np.float32)
    crop[..., 3:6] = 0.3                       # noisy radiance, working domain / 255
    crop[:, size // 2:, 3:6] = 0.6             # ... brighter on the right
    crop[..., 6] = 0.01                        # noise std
    crop[..., 7:10] = 0.5
    crop[:, size // 2:, 7:10] = 0.1            # albedo edge
    crop[..., 12] = 1.0                        # normal +z
    crop[..., 13] = 0.5                        # depth
    crop[..., 14] = 1.0                        # visibility
    crop[..., 15] = 1.0                        # coverage
    crop[..., 16] = feature_density(crop[..., 7:10], crop[..., 10:13], crop[..., 13], crop[..., 14], crop[..., 15])
    return crop


@pytest.mark.parametrize("pattern", ["random", "adaptive", "two_pass", "stratified"])
def test_crop_masks_spend_about_the_rate(pattern):
    from gmcpt.gan.data import crop_mask

    crop = training_crop()
    rng = np.random.default_rng(0)
    rates = [crop_mask(crop, 0.3, pattern, rng).mean() for _ in range(20)]
    assert np.mean(rates) == pytest.approx(0.3, abs=0.03)


@pytest.mark.parametrize("pattern", ["adaptive", "two_pass"])
def test_crop_masks_follow_the_edges(pattern):
    from gmcpt.gan.data import crop_mask

    crop = training_crop()
    near_edge = crop[..., 16] > 1.5
    masks = [crop_mask(crop, 0.2, pattern, np.random.default_rng(seed)) for seed in range(10)]
    assert np.mean([m[near_edge].mean() for m in masks]) > 1.5 * np.mean([m[~near_edge].mean() for m in masks])


def test_patch_sampler_refuses_an_unknown_pattern(tmp_path):
    from gmcpt.errors import GmcptError
    from gmcpt.gan.data import PatchSampler

    with pytest.raises(GmcptError, match="unknown mask pattern"):
        PatchSampler([tmp_path / "missing.npz"], masks=("random", "poisson"))
