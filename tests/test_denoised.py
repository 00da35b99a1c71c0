"""gan_oidn and gan_pawnnm_oidn: a fill, the traced samples put back, then Intel OIDN."""
import dataclasses

import numpy as np
import pytest

from conftest import synthetic_frame
from gmcpt.completion import Completion, complete, methods


def _noisy_frame(rate=0.3, sigma=0.08, seed=1):
    """The synthetic frame with Gaussian noise on its traced samples (and that noise as their variance)."""
    frame, clean = synthetic_frame(96, 128, rate=rate)
    noise = np.random.default_rng(seed).normal(0.0, sigma, frame.radiance.shape).astype(np.float32)
    radiance = np.where(frame.mask[..., None], np.maximum(clean + noise, 0.0), 0.0).astype(np.float32)
    variance = np.where(frame.mask, sigma ** 2, 0.0).astype(np.float32)
    return dataclasses.replace(frame, radiance=radiance, variance=variance), clean


def test_the_denoiser_sees_the_traced_samples_and_the_fill_elsewhere(monkeypatch):
    from gmcpt.completion import denoised

    frame, _ = _noisy_frame()
    fill = np.full(frame.radiance.shape, 0.25, np.float32)
    seen = {}

    def identity(image, albedo, normal, guide_rays):
        seen.update(image=image, albedo=albedo, normal=normal, guide_rays=guide_rays)
        return image.astype(np.float32)

    monkeypatch.setattr(denoised, "denoise_oidn", identity)
    result = denoised.denoise_over_fill(frame, lambda: Completion(fill, {"pre_completion_s": 0.1}))
    np.testing.assert_array_equal(result.image[frame.mask], frame.radiance[frame.mask])
    assert np.all(result.image[~frame.mask] == 0.25)
    assert seen["albedo"] is frame.albedo and seen["normal"] is frame.normal
    assert seen["guide_rays"] == 0  # over a fill the guides are never taken as clean
    assert result.timings["pre_completion_s"] == 0.1 and result.timings["denoise_s"] >= 0


@pytest.mark.parametrize("rays", [4, 16])
def test_a_frame_traced_everywhere_tells_oidn_its_guides_rays(monkeypatch, rays):
    from gmcpt.completion import denoised

    frame, _ = _noisy_frame()
    dense = dataclasses.replace(frame, mask=np.ones_like(frame.mask), info=frame.info.with_values(feature_spp=rays))
    seen = {}
    monkeypatch.setattr(denoised, "denoise_oidn", lambda image, albedo, normal, guide_rays: seen.update(
        rays=guide_rays) or image)
    denoised.denoise_over_fill(dense, lambda: pytest.fail("a dense frame has nothing to fill"))
    assert seen["rays"] == rays


def test_oidn_takes_guides_of_enough_rays_as_clean():
    from gmcpt.image.denoise import CLEAN_GUIDE_RAYS, denoise_oidn

    frame, _ = _noisy_frame()
    noisy = np.where(frame.mask[..., None], frame.radiance, 0.2).astype(np.float32)
    fewer = denoise_oidn(noisy, frame.albedo, frame.normal, CLEAN_GUIDE_RAYS - 1)
    assert np.array_equal(fewer, denoise_oidn(noisy, frame.albedo, frame.normal))
    assert not np.array_equal(fewer, denoise_oidn(noisy, frame.albedo, frame.normal, CLEAN_GUIDE_RAYS))


@pytest.mark.parametrize("method", ["gan_oidn", "gan_pawnnm_oidn"])
def test_oidn_methods_denoise_the_traced_pixels_and_fill_the_rest(method):
    assert method in methods()
    frame, clean = _noisy_frame()
    result = complete(frame, method)
    assert result.image.shape == clean.shape and np.isfinite(result.image).all()
    traced = frame.mask
    noisy_error = np.mean((frame.radiance[traced] - clean[traced]) ** 2)
    assert np.mean((result.image[traced] - clean[traced]) ** 2) < 0.5 * noisy_error
    assert np.mean((result.image[~traced] - clean[~traced]) ** 2) < noisy_error
    assert {"pre_completion_s", "denoise_s", "completion_s"} <= result.timings.keys()
    assert np.array_equal(complete(frame, method).image, result.image)  # same frame, same output


def test_gan_oidn_fills_with_gans_image_at_the_untraced_pixels(monkeypatch):
    """gan_oidn skips gan's blend of the samples back (it changes only the traced pixels, which the
    denoiser gets raw): what the denoiser sees is gan's image with the traced samples put back."""
    from gmcpt.completion import denoised

    frame, _ = _noisy_frame()
    seen = {}
    monkeypatch.setattr(denoised, "denoise_oidn", lambda image, albedo, normal, guide_rays: seen.setdefault("image",
                                                                                                       image))
    complete(frame, "gan_oidn")
    expected = np.where(frame.mask[..., None], frame.radiance, complete(frame, "gan").image)
    np.testing.assert_array_equal(seen["image"], expected)


@pytest.mark.parametrize("method", ["gan_oidn", "gan_pawnnm_oidn"])
def test_a_frame_with_every_pixel_traced_is_denoised_without_a_fill(monkeypatch, method):
    from gmcpt.completion import denoised

    frame, _ = _noisy_frame(rate=1.0)
    assert frame.mask.all()
    monkeypatch.setattr(denoised, "generator_fill", lambda *a, **k: pytest.fail("the generator ran"))
    monkeypatch.setattr(denoised, "complete_gan_pawnnm", lambda *a, **k: pytest.fail("the fill ran"))
    seen = {}
    monkeypatch.setattr(denoised, "denoise_oidn", lambda image, albedo, normal, guide_rays: seen.setdefault("image",
                                                                                                       image))
    result = complete(frame, method)
    np.testing.assert_array_equal(seen["image"], frame.radiance)
    assert "pre_completion_s" not in result.timings and "denoise_s" in result.timings


def test_oidn_loads_without_torch_and_torch_still_loads_after_it():
    """pyoidn imports torch where it can (5-6 s, for tensor inputs gmcpt never passes): a dense frame's process
    need not pay it, and the generator's torch must still import afterwards."""
    import subprocess
    import sys

    script = ("import sys, numpy as np\n"
              "from gmcpt.image.denoise import denoise_oidn\n"
              "image = np.random.default_rng(0).random((24, 24, 3), dtype=np.float32)\n"
              "first = denoise_oidn(image, image, image)\n"
              "print('torch' in sys.modules)\n"
              "import torch\n"
              "print(torch.ones(2).sum().item(), np.array_equal(first, denoise_oidn(image, image, image)))\n")
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["False", "2.0", "True"]
