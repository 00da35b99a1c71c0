import dataclasses

import numpy as np
import pytest

from conftest import synthetic_frame
from gmcpt.completion import complete, methods, register_method, Completion
from gmcpt.image.fills import push_pull
from gmcpt.errors import GmcptError


def psnr_linear(image, reference):
    return 10 * np.log10(1.0 / np.mean((image - reference) ** 2))


def test_registry_lists_shipped_methods():
    assert {"none", "interp"} <= set(methods())


def test_unknown_method():
    frame, _ = synthetic_frame()
    with pytest.raises(GmcptError, match="unknown completion method 'nope'"):
        complete(frame, "nope")


def test_none_is_the_sparse_image():
    frame, _ = synthetic_frame()
    result = complete(frame, "none")
    assert np.array_equal(result.image, np.where(frame.mask[..., None], frame.radiance, 0))
    assert result.timings["completion_s"] >= 0


def test_interp_keeps_samples_and_fills_well():
    frame, clean = synthetic_frame(rate=0.25)
    result = complete(frame, "interp")
    assert np.array_equal(result.image[frame.mask], frame.radiance[frame.mask])
    assert np.isfinite(result.image).all()
    # demodulation restores the checker texture from albedo: far better than the sparse input
    assert psnr_linear(result.image, clean) > psnr_linear(complete(frame, "none").image, clean) + 15
    assert psnr_linear(result.image, clean) > 35


def test_guided_fill_without_keeping_samples_smooths_them_and_keeps_edges():
    from gmcpt.image.fills import guided_fill

    rng = np.random.default_rng(3)
    height, width = 40, 40
    left = np.arange(width) < width // 2
    truth = np.where(left[None, :, None], 0.9, 0.1) * np.ones((height, width, 3), np.float32)
    noisy = (truth + rng.normal(0, 0.05, truth.shape)).astype(np.float32)
    mask = rng.random((height, width)) < 0.3
    features = np.zeros((height, width, 8), np.float32)
    features[:, left, 3] = 1   # normal x on the left, z on the right
    features[:, ~left, 5] = 1
    features[..., 6] = 1       # depth
    kept = guided_fill(noisy, mask, features)
    smoothed = guided_fill(noisy, mask, features, keep_samples=False)
    assert np.array_equal(kept[mask], noisy[mask])
    error = lambda image: np.sqrt(np.mean((image[mask] - truth[mask]) ** 2))  # noqa: E731
    assert error(smoothed) < 0.5 * error(kept)
    assert np.array_equal(smoothed[~mask], kept[~mask])
    assert np.abs(smoothed - truth).max() < 0.2   # no bleeding across the normal edge (a 0.8 step)


def test_guided_fill_is_the_same_on_one_thread_and_on_several(monkeypatch):
    """The fill's bands of rows run on threads: a frame of several bands (one of them short) gives the same
    image, bit for bit, whatever the thread count."""
    from gmcpt.image import fills

    rng = np.random.default_rng(5)
    monkeypatch.setattr(fills, "BAND_PIXELS", 16 * 40)
    height, width = 50, 40  # bands of 16 rows: 16, 16, 16 and 2
    values = rng.random((height, width, 3), np.float32)
    mask = rng.random((height, width)) < 0.3
    features = (0.5 + 0.2 * rng.random((height, width, 8))).astype(np.float32)
    images = []
    for threads in (1, 3):
        monkeypatch.setattr(fills, "cpu_threads", lambda threads=threads: threads)
        images.append(fills.guided_fill(values, mask, features, keep_samples=False))
    assert images[0].shape == (height, width, 3) and np.array_equal(images[0], images[1])
    # each band sees the rows of its neighbours: the same fill in one band of all rows
    monkeypatch.setattr(fills, "BAND_PIXELS", height * width)
    assert np.allclose(fills.guided_fill(values, mask, features, keep_samples=False), images[0], atol=1e-6)


def test_a_batch_is_filled_as_its_images_are_one_by_one():
    """The torch fill of a batch (its images at rates of two radii) is each image's own numpy guided fill."""
    import torch

    from gmcpt.image.fills import fill_batch, fill_radius, guided_fill

    rng = np.random.default_rng(7)
    rates = (0.15, 0.45, 0.2, 0.5)
    values = rng.random((4, 3, 24, 32), np.float32)
    masks = np.stack([rng.random((24, 32)) < rate for rate in rates])
    features = (0.5 + 0.3 * rng.random((4, 8, 24, 32))).astype(np.float32)
    assert len({fill_radius(mask.mean()) for mask in masks}) == 2
    batch = fill_batch(torch.from_numpy(values), torch.from_numpy(masks), torch.from_numpy(features),
                       keep_samples=False).numpy()
    for image, mask, aux, filled in zip(values, masks, features, batch):
        alone = guided_fill(np.moveaxis(image, 0, -1), mask, np.moveaxis(aux, 0, -1), keep_samples=False)
        np.testing.assert_allclose(np.moveaxis(filled, 0, -1), alone, atol=1e-5)  # numpy's |a|^2 + |b|^2 - 2 a.b


def test_interp_respects_feature_edges():
    """Two regions with different normals and radiance: the fill must not blur across."""
    frame, _ = synthetic_frame(rate=0.3)
    height, width = frame.shape
    left = np.arange(width) < width // 2
    truth = np.where(left[None, :, None], 0.9, 0.1) * np.ones((height, width, 3), np.float32)
    normal = np.zeros((height, width, 3), np.float32)
    normal[:, left, 0] = 1
    normal[:, ~left, 2] = 1
    edged = dataclasses.replace(frame, radiance=np.where(frame.mask[..., None], truth, 0).astype(np.float32),
                                albedo=np.zeros_like(frame.albedo), normal=normal)
    result = complete(edged, "interp")
    assert np.abs(result.image - truth).max() < 1e-3


def test_push_pull_fills_everything_from_one_sample():
    values = np.zeros((9, 7, 3), np.float32)
    weights = np.zeros((9, 7), np.float32)
    values[4, 3], weights[4, 3] = 2.0, 1.0
    filled = push_pull(values, weights)
    assert np.allclose(filled, 2.0)


def _pyramid_fill(values, weights):
    """push_pull written out plainly: block sums by reshape, the coarse level repeated up."""
    height, width = weights.shape
    if weights.sum() == 0:
        return np.zeros_like(values)
    if max(height, width) <= 1:
        return values * weights[..., None] / np.maximum(weights[..., None], 1e-12)
    even = ((0, height % 2), (0, width % 2))
    padded_w = np.pad(weights, even)
    padded_v = np.pad(values * weights[..., None], even + ((0, 0),))
    half_h, half_w = padded_w.shape[0] // 2, padded_w.shape[1] // 2
    sum_w = padded_w.reshape(half_h, 2, half_w, 2).sum(axis=(1, 3))
    sum_v = padded_v.reshape(half_h, 2, half_w, 2, -1).sum(axis=(1, 3))
    coarse = _pyramid_fill(sum_v / np.maximum(sum_w[..., None], 1e-12), np.minimum(sum_w, 1.0))
    up = np.repeat(np.repeat(coarse, 2, axis=0), 2, axis=1)[:height, :width]
    return weights[..., None] * values + (1.0 - weights[..., None]) * up


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (2, 2), (9, 7), (33, 64), (100, 37)])
def test_push_pull_matches_the_plain_pyramid(shape):
    rng = np.random.default_rng(sum(shape))
    values = rng.random((*shape, 3), dtype=np.float32)
    weights = np.where(rng.random(shape) < 0.3, rng.random(shape, dtype=np.float32), np.float32(0.0))
    weights.flat[-1] = 1.0  # never all empty
    filled = push_pull(values, weights)
    assert filled.shape == values.shape and filled.dtype == np.float32
    np.testing.assert_allclose(filled, _pyramid_fill(values, weights), rtol=1e-6, atol=1e-6)


def test_nonfinite_samples_are_dropped_not_spread():
    frame, clean = synthetic_frame(rate=0.4)
    radiance = frame.radiance.copy()
    traced = np.argwhere(frame.mask)
    for y, x in traced[:20]:
        radiance[y, x] = [np.nan, np.inf, 1.0]
    poisoned = dataclasses.replace(frame, radiance=radiance)
    result = complete(poisoned, "interp")
    assert np.isfinite(result.image).all()
    assert psnr_linear(result.image, clean) > 30


def test_min_size_is_enforced(monkeypatch):
    from gmcpt import completion
    monkeypatch.setattr(completion, "_REGISTRY", dict(completion._REGISTRY))

    @register_method("test_patchy", min_size=8)
    def patchy(frame):
        return Completion(np.zeros(frame.radiance.shape, np.float32))

    frame, _ = synthetic_frame(height=6, width=20)
    with pytest.raises(GmcptError, match="smaller than method 'test_patchy' needs"):
        complete(frame, "test_patchy")


def test_frame_validates_shapes():
    frame, _ = synthetic_frame()
    with pytest.raises(GmcptError, match="albedo"):
        dataclasses.replace(frame, albedo=np.zeros((3, 3, 3), np.float32))


def test_demodulation_factor_is_the_mean_of_the_rays_factors():
    from gmcpt.image.domain import WorkingDomain

    domain = WorkingDomain()
    eps = domain.albedo_eps
    # one pixel fully on a 0.4 albedo surface, one on the background, one with 1 ray of 4 on the surface
    albedo = np.array([[[0.4] * 3, [0.0] * 3, [0.1] * 3]], np.float32)
    coverage = np.array([[1.0, 0.0, 0.25]], np.float32)
    factor = domain.factor(albedo, coverage)[0, :, 0]
    np.testing.assert_allclose(factor, [0.4 + eps, 1.0, (0.4 + eps + 3 * 1.0) / 4], rtol=1e-6)
    # without a coverage buffer a pixel is demodulated or not: the silhouette pixel gets a tiny factor
    assert np.allclose(domain.factor(albedo)[0, :, 0], [0.4 + eps, 1.0, 0.1 + eps])
    frame, _ = synthetic_frame()
    covered = dataclasses.replace(frame, coverage=np.full(frame.shape, 0.5, np.float32))
    assert np.allclose(domain.frame_factor(covered), domain.factor(frame.albedo, covered.coverage))
    assert np.array_equal(domain.frame_factor(frame), domain.factor(frame.albedo))


@pytest.mark.cuda
def test_the_guided_fill_on_cuda_matches_the_cpu():
    """A training batch is filled where it lives: on the GPU, to float rounding each crop's numpy fill."""
    import torch

    from gmcpt.image.fills import fill_batch, guided_fill

    rng = np.random.default_rng(8)
    values = torch.from_numpy(rng.random((6, 3, 64, 48), np.float32))
    masks = torch.from_numpy(rng.random((6, 64, 48)) < np.linspace(0.15, 0.5, 6)[:, None, None])
    features = torch.from_numpy((0.5 + 0.3 * rng.random((6, 8, 64, 48))).astype(np.float32))
    on_gpu = fill_batch(values.cuda(), masks.cuda(), features.cuda(), keep_samples=False)
    assert on_gpu.is_cuda
    for image, mask, aux, filled in zip(values.numpy(), masks.numpy(), features.numpy(), on_gpu.cpu().numpy()):
        alone = guided_fill(np.moveaxis(image, 0, -1), mask, np.moveaxis(aux, 0, -1), keep_samples=False)
        np.testing.assert_allclose(np.moveaxis(filled, 0, -1), alone, atol=1e-5)


def test_complete_defaults_to_the_default_method():
    from gmcpt.completion import DEFAULT_METHOD

    frame = synthetic_frame(40, 48)[0]
    assert np.array_equal(complete(frame).image, complete(frame, DEFAULT_METHOD).image)
    assert not np.array_equal(complete(frame).image, complete(frame, "interp").image)
