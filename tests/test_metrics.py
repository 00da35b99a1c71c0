import numpy as np
import pytest

from gmcpt.image import metrics


@pytest.fixture
def image():
    rng = np.random.default_rng(0)
    return rng.uniform(0.05, 0.8, size=(32, 40, 3)).astype(np.float32)


def test_identical_images(image):
    assert metrics.mse(image, image) == 0
    assert metrics.psnr(image, image) == float("inf")
    assert metrics.ssim(image, image) == pytest.approx(1.0)
    assert metrics.relmse(image, image) == 0
    assert metrics.flip(image, image) == 0


def test_known_constant_offset_in_display_space():
    reference = np.full((16, 16, 3), 0.2, np.float32)
    shifted = np.full((16, 16, 3), 0.4, np.float32)
    def srgb(v):  # IEC 61966-2-1
        return 1.055 * v ** (1 / 2.4) - 0.055
    expected = (srgb(0.4) - srgb(0.2)) ** 2
    assert metrics.mse(shifted, reference) == pytest.approx(expected, rel=1e-5)
    assert metrics.psnr(shifted, reference) == pytest.approx(10 * np.log10(1 / expected), rel=1e-5)


def test_relmse_known_value():
    reference = np.full((4, 4, 3), 0.5, np.float32)
    assert metrics.relmse(reference + 0.1, reference) == pytest.approx(0.01 / (0.25 + 0.01), rel=1e-5)


def test_tonemap_clamps_and_matches_mitsuba_png_conversion(image):
    import gmcpt  # noqa: F401
    import mitsuba as mi
    hdr = image * 3
    bitmap = mi.Bitmap(hdr).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True)
    assert np.abs(np.round(metrics.tonemap(hdr) * 255) - np.asarray(bitmap)).max() <= 1
    assert metrics.tonemap(hdr).max() <= 1


def test_tonemap_is_the_srgb_standard_of_colour_science():
    import colour

    linear = np.concatenate([np.linspace(-1, 2, 4001, dtype=np.float32), np.float32([0.0031308, 0.0031309])])
    expected = colour.cctf_encoding(np.clip(linear.astype(np.float64), 0, 1), function="sRGB")
    assert metrics.tonemap(linear).dtype == np.float32
    assert np.abs(metrics.tonemap(linear) - expected).max() < 1e-6


def test_shape_mismatch(image):
    with pytest.raises(ValueError, match="shape"):
        metrics.mse(image, image[:-1])


def test_flip_grows_with_the_error(image):
    small = metrics.flip(image * 1.05, image)
    large = metrics.flip(image * 1.5, image)
    assert 0 < small < large <= 1
    assert set(metrics.all_metrics(image * 1.05, image)) == {"mse", "psnr", "ssim", "relmse", "flip"}


def test_block_psnr_averages_noise_out_and_keeps_a_shift():
    from gmcpt.image.metrics import block_psnr, psnr

    rng = np.random.default_rng(0)
    image = np.full((64, 48, 3), 0.3, np.float32)
    noisy = (image + rng.normal(0, 0.05, image.shape)).astype(np.float32)
    shifted = image * 1.1
    assert block_psnr(image, image) == float("inf")
    assert block_psnr(noisy, image) > psnr(noisy, image) + 15  # 8x8 blocks: noise variance / 64
    assert block_psnr(shifted, image) == pytest.approx(psnr(shifted, image), abs=1e-6)  # a uniform change stays
    assert np.isfinite(block_psnr(noisy[:5, :6], image[:5, :6]))  # smaller than one block
