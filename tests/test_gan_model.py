"""The GAN's networks (generator, critic) and the terms of its loss."""
import numpy as np
import pytest
import torch

from gan_helpers import SMALL, generator_inputs
from gmcpt.gan import losses
from gmcpt.gan.model import (Critic, CriticConfig, Generator, GeneratorConfig, ModulatedResBlock,
                             space_to_depth_conv)


def test_generator_starts_from_the_smoothed_feature_guided_fill_and_is_small():
    from gmcpt.image.fills import guided_fill

    generator = Generator()
    assert 0.3e6 < sum(p.numel() for p in generator.parameters()) < 1.0e6  # CPU-sized (docs/design.md section 3: well under 1.5 M)
    radiance, features = generator_inputs(batch=2, size=24, config=GeneratorConfig())
    out = generator(radiance, features)   # zero-initialised tail: the fill itself
    assert out.shape == radiance.shape
    for i in range(2):
        image = radiance[i].permute(1, 2, 0).numpy()
        aux = features[i].permute(1, 2, 0).numpy()
        expected = guided_fill(image, aux[..., 0] > 0, aux[..., 1:9], keep_samples=False)
        np.testing.assert_allclose(out[i].detach().permute(1, 2, 0).numpy(), expected, atol=1e-6)
    traced = features[:, :1].expand_as(radiance) > 0
    assert (out[traced] != radiance[traced]).float().mean() > 0.1   # traced pixels with like neighbours are averaged too


def test_space_to_depth_conv_equals_the_convolution_of_the_unshuffled_input():
    torch.manual_seed(0)
    conv = torch.nn.Conv2d(4 * 5, 6, 3, padding=1)
    x = torch.rand(2, 5, 12, 16, requires_grad=True)
    expected = conv(torch.nn.functional.pixel_unshuffle(x, 2))
    got = space_to_depth_conv(conv, x)
    torch.testing.assert_close(got, expected, rtol=1e-5, atol=1e-5)
    # and its gradients reach the same weights
    weight_grad = torch.autograd.grad(expected.square().sum(), conv.weight)[0]
    torch.testing.assert_close(torch.autograd.grad(got.square().sum(), conv.weight)[0], weight_grad,
                               rtol=1e-4, atol=1e-4)


def test_feature_modulation_is_scale_plus_one_and_shift():
    block = ModulatedResBlock(2, 1)
    with torch.no_grad():
        block.conv1.weight.zero_(); block.conv1.bias.fill_(1.0)   # h = 1 everywhere
        block.conv2.weight.zero_(); block.conv2.bias.fill_(0.0)   # second conv -> 0
        block.modulation.bias.zero_()
        block.modulation.weight.zero_()
        block.modulation.weight[4:6, 0] = 1.0   # scale2 = condition
        block.modulation.bias[6:8] = 0.5        # shift2 = 0.5
    x = torch.zeros(1, 2, 4, 4)
    condition = torch.full((1, 1, 4, 4), 3.0)
    # out = x + conv2(...) * (scale2 + 1) + shift2 = 0 + 0 * 4 + 0.5
    torch.testing.assert_close(block(x, condition), torch.full((1, 2, 4, 4), 0.5))


def test_conditioning_changes_the_output():
    torch.manual_seed(0)
    generator = Generator(SMALL)
    for parameter in generator.parameters():
        torch.nn.init.normal_(parameter, std=0.2)
    radiance, features = generator_inputs()
    other = features.clone()
    other[:, 1:4] = 1 - other[:, 1:4]   # change only the albedo
    assert not torch.allclose(generator(radiance, features), generator(radiance, other))


def test_critic_has_no_batch_norm_and_scores_each_sample():
    critic = Critic(SMALL.feature_channels, CriticConfig((8, 8)))
    assert not any(isinstance(m, torch.nn.modules.batchnorm._BatchNorm) for m in critic.modules())
    radiance, features = generator_inputs(batch=3)
    assert critic(radiance, features).shape == (3,)


def test_terms_vanish_for_identical_images():
    x = torch.rand(2, 3, 24, 24)
    extractor = losses.FixedFeatureExtractor()
    for term in (losses.l1_loss, losses.l2_loss, losses.sharpness_loss, losses.ssim_loss):
        assert float(term(x, x)) == pytest.approx(0.0, abs=1e-6)
    assert float(losses.perceptual_loss(extractor(x), extractor(x))) == 0.0


def test_ssim_matches_scikit_image():
    from skimage.metrics import structural_similarity

    rng = np.random.default_rng(0)
    a = rng.random((48, 48, 3)).astype(np.float32)
    b = np.clip(a + 0.1 * rng.standard_normal(a.shape), 0, 1).astype(np.float32)
    expected = structural_similarity(a, b, channel_axis=-1, data_range=1.0, gaussian_weights=True, sigma=1.5,
                                     use_sample_covariance=False)
    to = lambda x: torch.from_numpy(x).permute(2, 0, 1)[None]  # noqa: E731
    assert float(losses.ssim(to(a), to(b))) == pytest.approx(expected, abs=5e-3)


def test_sharpness_and_perceptual_terms_see_blur():
    torch.manual_seed(0)
    sharp = (torch.rand(1, 3, 32, 32) > 0.5).float()
    blurred = torch.nn.functional.avg_pool2d(sharp, 3, stride=1, padding=1, count_include_pad=False)
    shifted = sharp * 0.9 + 0.05   # same structure, other contrast
    extractor = losses.FixedFeatureExtractor()
    assert losses.sharpness_loss(blurred, sharp) > 5 * losses.sharpness_loss(shifted, sharp)
    assert losses.perceptual_loss(extractor(blurred), extractor(sharp)) > \
        losses.perceptual_loss(extractor(shifted), extractor(sharp))
    assert not list(extractor.parameters())  # fixed: nothing to train, nothing to download


def test_wasserstein_terms_and_gradient_penalty():
    real, fake = torch.tensor([2.0, 4.0]), torch.tensor([1.0, -1.0])
    assert float(losses.texture_loss(fake)) == 0.0
    assert float(losses.critic_loss(real, fake)) == pytest.approx(-3.0)
    assert float(losses.wasserstein_distance(real, fake)) == pytest.approx(3.0)

    class Linear(torch.nn.Module):   # D(x) = <w, x>: gradient norm |w| everywhere
        def __init__(self, norm):
            super().__init__()
            self.w = torch.full((1, 3, 4, 4), norm / np.sqrt(48))

        def forward(self, image, features):
            return (image * self.w).flatten(1).sum(1)

    x, y, f = torch.rand(2, 3, 4, 4), torch.rand(2, 3, 4, 4), torch.zeros(2, 1, 4, 4)
    assert float(losses.gradient_penalty(Linear(1.0), x, y, f)) == pytest.approx(0.0, abs=1e-6)
    assert float(losses.gradient_penalty(Linear(3.0), x, y, f)) == pytest.approx(4.0, rel=1e-4)


def test_hybrid_loss_uses_the_paper_weights():
    weights = losses.LossWeights()
    assert (weights.alpha, weights.beta, weights.gamma, weights.omega, weights.gp_lambda) == (0.005, 0.0095, 0.95, 0.095, 10)
    out, target = torch.rand(1, 3, 16, 16), torch.rand(1, 3, 16, 16)
    extractor = losses.FixedFeatureExtractor()
    total, terms = losses.hybrid_loss(out, target, torch.tensor([2.0]), extractor(out), extractor(target), weights)
    expected = (0.005 * terms["tex"] + 0.0095 * terms["per"] + 0.95 * terms["sharp"] + 0.095 * terms["ssim"]
                + weights.l1 * terms["l1"])
    assert float(total) == pytest.approx(expected, rel=1e-5) and terms["tex"] == -2.0


def test_tall_frames_run_in_bands_that_match_the_whole_frame_whatever_the_threads():
    from gmcpt.gan.infer import BAND_HALO, bands, generate
    from gmcpt.gan.weights import load_generator

    assert bands(256, 8) == [(0, 256)]
    layout = bands(1088, 8)
    assert len(layout) == 2 and layout[0][0] == 0 and layout[-1][1] == 1088
    assert all(a[1] == b[0] and a[1] % 8 == 0 for a, b in zip(layout, layout[1:]))

    generator, _ = load_generator(None)
    radiance, features = generator_inputs(batch=1, size=1024, config=generator.config)
    radiance, features = radiance[..., :32].contiguous(), features[..., :32].contiguous()   # 1024 x 32: two bands
    with torch.inference_mode():
        whole = generator(radiance, features)
    one, two = generate(generator, radiance, features, 1), generate(generator, radiance, features, 2)
    assert torch.equal(one, two)                       # the bands, not the threads, decide the output
    assert BAND_HALO % generator.multiple == 0
    difference = (two - whole).abs()
    assert float(difference.max()) < 1e-3 and float(whole.std()) > 1e-2


def test_generator_runs_channels_last_on_the_cpu_with_the_same_output():
    import copy

    from gmcpt.gan.infer import generate, memory_format, prepare
    from gmcpt.gan.weights import load_generator

    shipped, _ = load_generator(None)
    plain = copy.deepcopy(shipped).to(memory_format=torch.contiguous_format)
    radiance, features = generator_inputs(batch=1, size=64, config=plain.config)
    with torch.inference_mode():
        reference = plain(radiance.contiguous(), features.contiguous())
    prepared = prepare(copy.deepcopy(plain), "cpu")
    assert memory_format("cpu") == torch.channels_last and memory_format("cuda") == torch.contiguous_format
    assert prepared.head.weight.is_contiguous(memory_format=torch.channels_last)
    output = generate(prepared, radiance, features)
    assert float((output - reference).abs().max()) < 1e-4 and float(reference.std()) > 1e-2


def test_the_networks_make_no_tensor_off_their_device():
    """On PyTorch's data-less ``meta`` device a tensor made on the CPU inside a forward pass fails at once, as it
    does on a GPU (a bias made without the condition's device stopped the first training step on CUDA)."""
    radiance, features = (t.to("meta") for t in generator_inputs())
    generator, critic = Generator(SMALL).to("meta"), Critic(SMALL.feature_channels, CriticConfig(widths=(8, 8))).to("meta")
    fake = generator(radiance, features, torch.empty_like(radiance))
    penalty = losses.gradient_penalty(critic, fake, fake.detach(), features)
    (critic(fake, features).mean() + penalty + sum(f.mean() for f in losses.FixedFeatureExtractor().to("meta")(fake))
     ).backward()
    assert fake.shape == radiance.shape and fake.device.type == "meta"
    assert all(p.grad is not None and p.grad.device.type == "meta" for p in generator.parameters())
