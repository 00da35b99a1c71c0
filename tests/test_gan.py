"""GAN pre-completion: model, loss terms, weights I/O, training loop, completion methods."""
import json
import math

import numpy as np
import pytest
import torch

from gmcpt.errors import GmcptError
from gmcpt.gan import losses
from gmcpt.gan.model import Critic, CriticConfig, Generator, GeneratorConfig, ModulatedResBlock, push_pull

SMALL = GeneratorConfig(widths=(8, 8, 8), encoder_blocks=(1, 1, 1), decoder_blocks=(1, 1), condition_width=4)


def _inputs(batch=2, size=16, config=SMALL, seed=0):
    generator = torch.Generator().manual_seed(seed)
    mask = (torch.rand(batch, 1, size, size, generator=generator) < 0.3).float()
    radiance = torch.rand(batch, 3, size, size, generator=generator) * mask
    rest = torch.rand(batch, config.feature_channels - 1, size, size, generator=generator)
    return radiance, torch.cat([mask, rest], 1)


# ----------------------------------------------------------------------------- model

def test_push_pull_keeps_known_pixels_and_fills_constants():
    mask = (torch.rand(1, 1, 13, 10) < 0.2).float()
    mask[0, 0, 0, 0] = 1
    values = torch.full((1, 3, 13, 10), 0.7) * mask
    filled = push_pull(values, mask)
    torch.testing.assert_close(filled, torch.full_like(filled, 0.7))


def test_generator_starts_from_the_fill_and_is_small():
    generator = Generator()
    assert 0.3e6 < sum(p.numel() for p in generator.parameters()) < 1.0e6  # CPU-sized (docs/design.md section 3: well under 1.5 M)
    radiance, features = _inputs(config=GeneratorConfig())
    out = generator(radiance, features)
    assert out.shape == radiance.shape
    # the tail is zero-initialised: an untrained generator returns the push-pull fill
    torch.testing.assert_close(out, push_pull(radiance, features[:, :1]))


@pytest.mark.parametrize("base, keep_samples, radius_scale",
                         [("guided", True, 1.0), ("guided_smooth", False, 1.0), ("guided_smooth", False, 2.0)])
def test_guided_bases_are_the_classical_feature_guided_fill(base, keep_samples, radius_scale):
    from dataclasses import replace

    from gmcpt.completion.classical import GuidedFillParams, guided_fill

    config = replace(SMALL, base=base, base_radius_scale=radius_scale)
    radiance, features = _inputs(batch=2, size=24, config=config)
    out = Generator(config)(radiance, features)   # zero-initialised tail: the base itself
    for i in range(2):
        image = radiance[i].permute(1, 2, 0).numpy()
        aux = features[i].permute(1, 2, 0).numpy()
        mask = aux[..., 0] > 0
        radius = math.ceil(radius_scale * 1.5 / math.sqrt(mask.mean()))   # the window the scale widens
        expected = guided_fill(image, mask, aux[..., 1:9], GuidedFillParams(radius=radius), keep_samples)
        np.testing.assert_allclose(out[i].detach().permute(1, 2, 0).numpy(), expected, atol=1e-6)
    assert not torch.allclose(out, push_pull(radiance, features[:, :1]))
    traced = features[:, :1].expand_as(radiance) > 0
    changed = (out[traced] != radiance[traced]).float().mean()
    assert changed == 0 if keep_samples else changed > 0.1   # the smooth base averages traced pixels too (those with like neighbours)


def test_guided_base_config_is_checked():
    with pytest.raises(ValueError, match="generator base must be one of"):
        GeneratorConfig(base="bilinear")
    with pytest.raises(ValueError, match="base_radius_scale must be > 0"):
        GeneratorConfig(base="guided", base_radius_scale=0.0)


def test_kernel_head_is_a_weighted_mean_of_traced_samples_and_the_fill():
    from gmcpt.gan.model import KernelHead

    torch.manual_seed(0)
    head = KernelHead(6, 5)
    torch.nn.init.normal_(head.conv.weight, std=0.5)   # a trained-looking head: arbitrary logits
    with torch.no_grad():
        head.conv.weight[-12:].zero_(); head.conv.bias[-12:].zero_()   # correction 0
    x = torch.randn(1, 6, 12, 12)
    mask = (torch.rand(1, 1, 24, 24) < 0.3).float()
    radiance, fill = torch.rand(1, 3, 24, 24) * mask, torch.rand(1, 3, 24, 24)
    # a constant image comes back constant: the weights are a convex combination
    torch.testing.assert_close(head(x, torch.full_like(radiance, 0.6) * mask, mask, torch.full_like(fill, 0.6)),
                               torch.full_like(radiance, 0.6))
    # what sits under untraced pixels never reaches the output
    out = head(x, radiance, mask, fill)
    torch.testing.assert_close(head(x, radiance + 5.0 * (1 - mask), mask, fill), out)
    # a traced sample reaches the pixels of its 5x5 window, and no others
    y, x0 = 12, 12
    mask[0, 0, y, x0] = 1
    out = head(x, radiance, mask, fill)
    bumped = radiance.clone(); bumped[0, :, y, x0] += 1.0
    changed = (head(x, bumped, mask, fill) - out).abs().amax(1)[0] > 1e-6
    assert changed[y - 2:y + 3, x0 - 2:x0 + 3].all() and changed.sum() == 25
    # with no traced pixel in reach, the output is the fill
    empty = torch.zeros_like(mask)
    torch.testing.assert_close(head(x, radiance * 0, empty, fill), fill)
    # a whole generator with this head runs end to end
    generator = Generator(GeneratorConfig(widths=(8, 8, 8), condition_width=4, output="kernel", kernel_size=5))
    radiance, features = _inputs(batch=1, size=16)
    assert torch.isfinite(generator(radiance, features)).all()
    with pytest.raises(ValueError, match="generator output must be one of"):
        GeneratorConfig(output="pixels")
    with pytest.raises(ValueError, match="kernel_size must be a positive odd number"):
        GeneratorConfig(output="kernel", kernel_size=4)


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
    radiance, features = _inputs()
    other = features.clone()
    other[:, 1:4] = 1 - other[:, 1:4]   # change only the albedo
    assert not torch.allclose(generator(radiance, features), generator(radiance, other))


def test_critic_has_no_batch_norm_and_scores_each_sample():
    critic = Critic(SMALL.feature_channels, CriticConfig((8, 8)))
    assert not any(isinstance(m, torch.nn.modules.batchnorm._BatchNorm) for m in critic.modules())
    radiance, features = _inputs(batch=3)
    assert critic(radiance, features).shape == (3,)


# ----------------------------------------------------------------------------- loss terms

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
    assert "display" not in terms   # off unless a config weights it


def test_display_loss_compares_tonemapped_images_and_joins_the_total_when_weighted():
    from gmcpt.metrics import tonemap

    linear = torch.tensor([0.0, 0.002, 0.2, 0.9, 3.0]).reshape(1, 1, 1, 5)
    assert np.allclose(losses.srgb(linear).numpy(), tonemap(linear.numpy()), atol=1e-6)
    bright = linear + torch.tensor([0.0, 0.0, 0.0, 0.0, 5.0]).reshape(1, 1, 1, 5)   # only above the clamp
    assert float(losses.display_loss(bright, linear)) == 0.0
    darker = linear * 0.5
    expected = np.abs(tonemap(darker.numpy()) - tonemap(linear.numpy())).mean()
    assert float(losses.display_loss(darker, linear)) == pytest.approx(expected, rel=1e-5)
    dark = torch.zeros(1, 1, 1, 1, requires_grad=True)   # the curve's steep start keeps a finite gradient
    losses.display_loss(dark + 0.0, torch.full((1, 1, 1, 1), 0.5)).backward()
    assert torch.isfinite(dark.grad).all() and float(dark.grad) < 0

    weights = losses.LossWeights(display=2.0)
    out, target = torch.rand(1, 3, 16, 16), torch.rand(1, 3, 16, 16)
    extractor = losses.FixedFeatureExtractor()
    with pytest.raises(ValueError, match="linear radiance"):
        losses.hybrid_loss(out, target, None, extractor(out), extractor(target), weights)
    total, terms = losses.hybrid_loss(out, target, None, extractor(out), extractor(target), weights, (out, target))
    plain, _ = losses.hybrid_loss(out, target, None, extractor(out), extractor(target), losses.LossWeights())
    assert terms["display"] == pytest.approx(float(losses.display_loss(out, target)))
    assert float(total) == pytest.approx(float(plain) + 2.0 * terms["display"], rel=1e-5)


# ----------------------------------------------------------------------------- weights

def test_weights_round_trip_and_metadata(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights, sha256

    generator = Generator(SMALL)
    torch.nn.init.normal_(generator.tail.weight, std=0.1)
    record = save_weights(tmp_path / "w.pt", generator, {"config": {"x": 1}, "dataset": {"version": 1}})
    assert record["sha256"] == sha256(tmp_path / "w.pt")
    assert json.loads((tmp_path / "w.json").read_text())["dataset"]["version"] == 1
    payload = torch.load(tmp_path / "w.pt", weights_only=True)   # plain tensors and strings only
    stored = [t for t in payload["state_dict"].values() if t.is_floating_point()]
    assert stored and all(t.dtype == torch.float16 for t in stored)
    assert json.loads((tmp_path / "w.json").read_text())["stored_dtype"] == "float16"
    loaded, meta = load_generator(tmp_path / "w.pt")
    assert all(p.dtype == torch.float32 for p in loaded.parameters())
    rounded = Generator(SMALL)   # the generator as stored: its weights rounded to half precision
    rounded.load_state_dict({k: v.half().float() if v.is_floating_point() else v
                             for k, v in generator.state_dict().items()})
    radiance, features = _inputs()
    torch.testing.assert_close(loaded(radiance, features), rounded(radiance, features).detach())
    assert meta["config"] == {"x": 1}


def test_weights_too_large_for_half_precision_are_stored_as_they_are(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights

    generator = Generator(SMALL)
    with torch.no_grad():
        generator.tail.weight[0, 0, 0, 0] = 1e6   # beyond float16's range (65504)
    save_weights(tmp_path / "big.pt", generator, {})
    stored = torch.load(tmp_path / "big.pt", weights_only=True)["state_dict"]
    assert stored["tail.weight"].dtype == torch.float32 and stored["tail.bias"].dtype == torch.float16
    loaded, _ = load_generator(tmp_path / "big.pt")
    assert loaded.tail.weight[0, 0, 0, 0].item() == 1e6


def test_missing_or_corrupt_weights_give_one_line_with_the_fix(tmp_path):
    from gmcpt.gan.weights import load_generator, save_weights

    with pytest.raises(GmcptError, match="not found.*retrain with `python -m gmcpt train"):
        load_generator(tmp_path / "absent.pt")
    path = tmp_path / "bad.pt"
    save_weights(path, Generator(SMALL), {})
    path.write_bytes(path.read_bytes()[:500])
    for check_hash, pattern in ((True, "sha256"), (False, "corrupt")):
        with pytest.raises(GmcptError, match=pattern) as error:
            load_generator(path, check_hash=check_hash)
        assert "\n" not in str(error.value) and "retrain" in str(error.value)


# ----------------------------------------------------------------------------- training

def _tiny_dataset(root, count=2, size=24):
    from gmcpt.dataset.build import save_example
    from tests.conftest import synthetic_frame

    for split, base in (("train", 0), ("val", 1_000_000)):
        for index in range(count):
            frame, clean = synthetic_frame(size, size, 0.3, seed=index)
            arrays = {"reference": clean, "radiance": frame.radiance, "mask": frame.mask, "variance": frame.variance,
                      "albedo": frame.albedo, "normal": frame.normal, "depth": frame.depth,
                      "visibility": frame.visibility, "full_radiance": clean * 1.05, "full_variance": frame.variance + 1e-3}
            meta = {"version": 1, "seed": base + index, "split": split, "spp": 16, "reference_spp": 512, "rate": 0.3}
            save_example(root / split / f"{base + index:07d}.npz", {"arrays": arrays, "meta": meta})
    (root / "manifest.json").write_text(json.dumps({"version": 1}))


def test_training_checkpoints_resumes_and_exports(tmp_path, monkeypatch):
    from gmcpt.gan import cli, weights
    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    _tiny_dataset(data)
    overrides = {"train.dataset": str(data), "train.steps": 2, "train.max_train_scenes": 0, "train.batch": 2, "train.crop": 16,
                 "train.eval_every": 2, "train.checkpoint_every": 1, "critic.widths": [8, 8],
                 "generator.widths": [8, 8, 8], "generator.encoder_blocks": [1, 1, 1], "generator.condition_width": 4}
    config = load_config("cpu", overrides)
    out = tmp_path / "run"
    first = Trainer(config, out, lambda m: None).run()
    assert first["steps"] == 2 and (out / "checkpoint.pt").is_file() and (out / "curves.png").is_file()
    history = json.loads((out / "history.json").read_text())
    assert {"l1", "l2", "wdist"} <= set(history[1]) and any("val_psnr" in h for h in history)
    resumed = Trainer(load_config("cpu", {**overrides, "train.steps": 3}), out, lambda m: None)
    with pytest.raises(ValueError, match="another config"):
        resumed.run()   # a changed config never silently resumes
    again = Trainer(config, out, lambda m: None)
    assert again.load_checkpoint() and again.step == 2
    monkeypatch.setattr(weights, "WEIGHTS_DIR", tmp_path / "shipped")
    record = cli.export(again, "tiny", "python -m gmcpt train ...")
    assert record["dataset"]["version"] == 1 and (tmp_path / "shipped" / "tiny.pt").is_file()


def test_weight_average_follows_each_step_resumes_and_is_what_gets_exported(tmp_path, monkeypatch):
    from gmcpt.gan import cli, weights
    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    _tiny_dataset(data)
    overrides = {"train.dataset": str(data), "train.steps": 2, "train.max_train_scenes": 0, "train.batch": 2,
                 "train.crop": 16, "train.eval_every": 2, "train.checkpoint_every": 1, "train.ema": 0.75,
                 "critic.widths": [8, 8], "generator.widths": [8, 8, 8], "generator.encoder_blocks": [1, 1, 1],
                 "generator.condition_width": 4}
    trainer = Trainer(load_config("cpu", overrides), tmp_path / "run", lambda m: None)
    before = {k: v.clone() for k, v in trainer.averaged.state_dict().items()}
    trainer.train_step()
    after = trainer.generator.state_dict()
    for name, average in trainer.averaged.state_dict().items():
        torch.testing.assert_close(average, 0.75 * before[name] + 0.25 * after[name])
    assert trainer.trained is trainer.averaged
    assert not all(torch.equal(a, b) for a, b in zip(trainer.averaged.state_dict().values(), after.values()))

    done = Trainer(load_config("cpu", overrides), tmp_path / "run", lambda m: None)
    done.run()
    resumed = Trainer(load_config("cpu", overrides), tmp_path / "run", lambda m: None)
    assert resumed.load_checkpoint()
    for a, b in zip(resumed.averaged.state_dict().values(), done.averaged.state_dict().values()):
        assert torch.equal(a, b)
    monkeypatch.setattr(weights, "WEIGHTS_DIR", tmp_path / "shipped")
    cli.export(resumed, "tiny", "python -m gmcpt train ...")
    exported, _ = weights.load_generator(str(tmp_path / "shipped" / "tiny.pt"))
    for a, b in zip(exported.state_dict().values(), done.averaged.state_dict().values()):
        torch.testing.assert_close(a, b, atol=1e-3, rtol=1e-3)   # stored in half precision
    with pytest.raises(ValueError, match="train.ema must be in"):
        Trainer(load_config("cpu", {**overrides, "train.ema": 1.0}), tmp_path / "bad", lambda m: None)
    with pytest.raises(ValueError, match="train.reference_denoiser must be one of none, oidn"):
        load_config("cpu", {"train.reference_denoiser": "median"})


def test_extra_datasets_join_the_training_scenes_and_the_weights_record_them(tmp_path, monkeypatch):
    from gmcpt.gan import cli, weights
    from gmcpt.gan.train import Trainer, load_config

    main, extra = tmp_path / "data", tmp_path / "interiors"
    _tiny_dataset(main)
    _tiny_dataset(extra, count=3)
    overrides = {"train.dataset": str(main), "train.steps": 1, "train.max_train_scenes": 1, "train.batch": 2,
                 "train.crop": 16, "train.eval_every": 1, "critic.widths": [8, 8], "generator.widths": [8, 8, 8],
                 "generator.encoder_blocks": [1, 1, 1], "generator.condition_width": 4,
                 "train.extra_datasets": [str(extra)]}
    trainer = Trainer(load_config("cpu", overrides), tmp_path / "run", lambda m: None)
    assert trainer.train_sets == [(str(main), [0]), (str(extra), [0, 1, 2])]
    assert len(trainer.sampler.scenes) == 4
    trainer.run()
    monkeypatch.setattr(weights, "WEIGHTS_DIR", tmp_path / "shipped")
    record = cli.export(trainer, "tiny", "python -m gmcpt train ...")
    assert record["dataset"]["train_scenes"] == 1
    assert [(e["path"], e["train_scenes"]) for e in record["dataset"]["extra_datasets"]] == [(str(extra), 3)]
    with pytest.raises(ValueError, match="no training scenes"):
        Trainer(load_config("cpu", {**overrides, "train.extra_datasets": [str(tmp_path / "missing")]}),
                tmp_path / "run2", lambda m: None)


def test_progress_before_the_critic_starts_says_so_without_warnings(tmp_path):
    import warnings

    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    _tiny_dataset(data)
    config = load_config("cpu", {"train.dataset": str(data), "train.steps": 4, "train.max_train_scenes": 0,
                                 "train.batch": 2, "train.crop": 16, "train.eval_every": 1, "train.critic_start": 2,
                                 "train.critic_every": 1, "critic.widths": [8, 8], "generator.widths": [8, 8, 8],
                                 "generator.encoder_blocks": [1, 1, 1], "generator.condition_width": 4})
    messages = []
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # np.nanmean of nothing used to warn "Mean of empty slice"
        Trainer(config, tmp_path / "run", messages.append).run()
    progress = [m for m in messages if m.startswith("step ")]
    assert "wdist - (critic not started)" in progress[0] and "wdist -0" not in progress[0]
    assert "critic not started" not in progress[-1] and "wdist " in progress[-1]


def test_patch_sampler_autoexposure_brings_scenes_to_the_product_exposure(tmp_path):
    from gmcpt.dataset import list_examples
    from gmcpt.domain import WorkingDomain
    from gmcpt.gan.data import SCALE, PatchSampler
    from gmcpt.gan.infer import EXPOSURE_TARGET

    _tiny_dataset(tmp_path)
    paths = list_examples(tmp_path, "train")
    plain = PatchSampler(paths, crop=16)
    exposed = PatchSampler(paths, crop=16, autoexposure=True)
    domain = WorkingDomain()
    for scene, same in zip(exposed.scenes, plain.scenes):
        # noisy radiance channels back to linear (demodulation factor from the albedo channels)
        factor = domain.factor(scene[..., 7:10])
        noisy = domain.inverse(scene[..., 3:6] * SCALE, factor)
        assert np.percentile(noisy.mean(axis=-1), 95) == pytest.approx(EXPOSURE_TARGET, rel=1e-3)
        assert np.array_equal(scene[..., 7:16], same[..., 7:16])   # features untouched


def test_reference_noise_estimate_and_the_training_filter_on_it(tmp_path):
    from gmcpt.dataset import list_examples, load_example
    from gmcpt.gan.data import PatchSampler, reference_noise_psnr

    flat = {"meta": {"spp": 16, "reference_spp": 512}, "reference": np.full((4, 4, 3), 0.5, np.float32),
            "full_variance": np.full((4, 4), 1e-3, np.float32)}
    slope = 1.055 / 2.4 * 0.5 ** (1 / 2.4 - 1)
    assert reference_noise_psnr(flat) == pytest.approx(-10 * np.log10(1e-3 * 16 / 512 * slope ** 2), rel=1e-5)
    more_samples = {**flat, "meta": {"spp": 16, "reference_spp": 2048}}
    assert reference_noise_psnr(more_samples) == pytest.approx(reference_noise_psnr(flat) + 10 * np.log10(4), rel=1e-5)
    assert reference_noise_psnr({**flat, "reference": flat["reference"] + 1.0}) == float("inf")   # all clipped

    from gmcpt.dataset.build import save_example

    _tiny_dataset(tmp_path, count=3)
    paths = list_examples(tmp_path, "train")
    for noise, path in zip((1.0, 10.0, 100.0), paths):   # one scene's reference 10x noisier than the next
        example = load_example(path)
        meta = example.pop("meta")
        example["full_variance"] = example["full_variance"] * noise
        save_example(path, {"arrays": example, "meta": meta})
    estimates = sorted(reference_noise_psnr(load_example(p)) for p in paths)
    threshold = (estimates[0] + estimates[1]) / 2
    sampler = PatchSampler(paths, crop=16, min_reference_psnr=threshold)
    assert len(sampler.scenes) == 2 and len(sampler.skipped) == 1
    assert reference_noise_psnr(load_example(sampler.skipped[0])) == estimates[0]


def test_reference_denoiser_removes_speckle_and_keeps_the_level():
    pytest.importorskip("pyoidn")
    from gmcpt.denoise import clean_reference

    size = 64
    clean = np.full((size, size, 3), 0.4, np.float32)
    clean[:, size // 2:] = 0.1                                     # two flat regions
    speckled = (clean * np.random.default_rng(3).gamma(2.0, 0.5, clean.shape)).astype(np.float32)
    example = {"reference": speckled, "albedo": np.full_like(clean, 0.5),
               "normal": np.broadcast_to(np.float32([0, 0, 1]), clean.shape).copy()}
    cleaned = clean_reference(example, "oidn")
    assert np.mean((cleaned - clean) ** 2) < 0.1 * np.mean((speckled - clean) ** 2)
    for half in (slice(4, size // 2 - 4), slice(size // 2 + 4, size - 4)):
        assert cleaned[:, half].mean() == pytest.approx(clean[:, half].mean(), rel=0.05)
    assert cleaned.min() >= 0 and np.array_equal(clean_reference(example, "oidn"), cleaned)
    assert clean_reference(example, "none") is speckled
    with pytest.raises(ValueError, match="reference denoiser"):
        clean_reference(example, "median")


def test_patch_sampler_trains_on_the_denoised_references(tmp_path):
    pytest.importorskip("pyoidn")
    from gmcpt.dataset import list_examples, load_example
    from gmcpt.denoise import clean_reference
    from gmcpt.domain import WorkingDomain
    from gmcpt.gan.data import PatchSampler, working_to_radiance

    _tiny_dataset(tmp_path)
    paths = list_examples(tmp_path, "train")
    to_tensor = lambda a: torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None]  # noqa: E731
    sampler = PatchSampler(paths, crop=16, reference_denoiser="oidn")
    for scene, path in zip(sampler.scenes, paths):
        target = working_to_radiance(to_tensor(scene[..., 0:3]), to_tensor(scene[..., 16:19]), WorkingDomain())
        example = load_example(path)
        expected = clean_reference(example, "oidn")
        assert not np.allclose(expected, example["reference"], atol=1e-3)
        assert np.allclose(target[0].numpy().transpose(1, 2, 0), expected, rtol=1e-4, atol=1e-5)


def test_sampled_targets_map_back_to_the_reference_at_its_own_exposure(tmp_path):
    from gmcpt.dataset import list_examples, load_example
    from gmcpt.domain import WorkingDomain
    from gmcpt.gan.data import PatchSampler, working_to_radiance

    _tiny_dataset(tmp_path)
    paths = list_examples(tmp_path, "train")
    to_tensor = lambda a: torch.from_numpy(np.ascontiguousarray(a.transpose(2, 0, 1)))[None]  # noqa: E731
    for autoexposure in (False, True):
        sampler = PatchSampler(paths, crop=16, autoexposure=autoexposure)
        for scene, path in zip(sampler.scenes, paths):
            back = working_to_radiance(to_tensor(scene[..., 0:3]), to_tensor(scene[..., 16:19]), WorkingDomain())
            reference = load_example(path)["reference"]
            assert np.allclose(back[0].numpy().transpose(1, 2, 0), reference, rtol=1e-4, atol=1e-5)
        batch = sampler.batch(np.random.default_rng(0), 2, use_variance=True)
        assert batch.to_radiance.shape == batch.target.shape


def test_coverage_feature_is_the_frames_buffer_or_the_0_1_rule(tmp_path):
    import dataclasses

    from gmcpt.dataset import list_examples
    from gmcpt.domain import WorkingDomain
    from gmcpt.gan.data import PatchSampler, frame_inputs
    from tests.conftest import synthetic_frame

    frame, _ = synthetic_frame(16, 16)
    coverage = np.linspace(0, 1, 256, dtype=np.float32).reshape(16, 16)
    with_buffer = dataclasses.replace(frame, coverage=coverage)
    config = GeneratorConfig(use_coverage=True)
    _, plain, _ = frame_inputs(with_buffer, WorkingDomain(), use_variance=True)
    _, features, _ = frame_inputs(with_buffer, WorkingDomain(), use_variance=True, use_coverage=True)
    assert features.shape[1] == config.feature_channels == plain.shape[1] + 1
    assert torch.equal(features[:, :-1], plain)
    assert np.array_equal(features[0, -1].numpy(), coverage)
    _, rule, _ = frame_inputs(dataclasses.replace(frame, coverage=None), WorkingDomain(), True, True)
    assert np.array_equal(rule[0, -1].numpy(), (frame.albedo.max(-1) >= 0.02).astype(np.float32))

    _tiny_dataset(tmp_path)
    sampler = PatchSampler(list_examples(tmp_path, "train"), crop=16)
    batch = sampler.batch(np.random.default_rng(0), 4, use_variance=True, use_coverage=True).features
    assert batch.shape[1] == config.feature_channels
    # the tiny dataset's files have no coverage buffer: the 0/1 rule over the crop's albedo channels
    assert torch.equal(batch[:, -1], (batch[:, 1:4].amax(1) >= 0.02).float())
    generator = Generator(dataclasses.replace(SMALL, use_coverage=True))
    radiance, _ = _inputs(batch=4)
    assert generator(radiance, batch[:, :generator.config.feature_channels]).shape == (4, 3, 16, 16)


def test_train_cli_reports_a_missing_dataset(tmp_path, capsys):
    from gmcpt.gan.cli import main

    assert main(["--config", "cpu", "--dataset", str(tmp_path / "none"), "--out", str(tmp_path / "r")]) == 2
    assert "python -m gmcpt dataset" in capsys.readouterr().err


def test_presets_load():
    from gmcpt.gan.train import load_config

    cpu, gpu = load_config("cpu"), load_config("gpu")
    assert cpu.train.device == "cpu" and gpu.train.device == "cuda"
    assert cpu.generator.base == gpu.generator.base == "guided_smooth"
    assert cpu.loss == losses.LossWeights()


# ----------------------------------------------------------------------------- completion methods

def test_gan_method_with_given_weights(tmp_path):
    from gmcpt.completion import complete
    from gmcpt.gan.weights import save_weights
    from tests.conftest import synthetic_frame

    save_weights(tmp_path / "g.pt", Generator(SMALL), {})
    frame, clean = synthetic_frame(30, 36)   # not a multiple of 8: padded and cropped
    result = complete(frame, "gan", weights=str(tmp_path / "g.pt"))
    assert result.image.shape == (30, 36, 3) and np.isfinite(result.image).all()
    assert "pre_completion_s" in result.timings


def test_autoexposure_sets_the_95th_percentile():
    import dataclasses

    from gmcpt.gan.infer import EXPOSURE_TARGET, autoexposure, exposed
    from tests.conftest import synthetic_frame

    frame, _ = synthetic_frame()
    exposure = autoexposure(frame)
    brought = exposed(frame, exposure)
    level = np.percentile(brought.radiance[brought.mask].mean(axis=-1), 95)
    assert level == pytest.approx(EXPOSURE_TARGET, rel=1e-4)
    assert np.allclose(brought.variance, frame.variance * exposure ** 2)
    assert autoexposure(dataclasses.replace(frame, mask=np.zeros_like(frame.mask))) == 1.0


def test_gan_output_follows_the_exposure_of_its_input(tmp_path):
    """Autoexposure: a frame 7x brighter completes to a 7x brighter image (same network input)."""
    import dataclasses

    from gmcpt.completion import complete
    from gmcpt.gan.weights import save_weights
    from tests.conftest import synthetic_frame

    torch.manual_seed(0)
    generator = Generator(SMALL)
    for parameter in generator.parameters():
        torch.nn.init.normal_(parameter, std=0.1)
    save_weights(tmp_path / "g.pt", generator, {})
    frame, _ = synthetic_frame(32, 32)
    frame = dataclasses.replace(frame, variance=np.where(frame.mask, 1e-3, 0).astype(np.float32))
    bright = dataclasses.replace(frame, radiance=frame.radiance * 7, variance=frame.variance * 49)
    image = complete(frame, "gan", weights=str(tmp_path / "g.pt")).image
    np.testing.assert_allclose(complete(bright, "gan", weights=str(tmp_path / "g.pt")).image, 7 * image,
                               rtol=1e-4, atol=1e-6)


def test_shipped_weights_match_their_metadata():
    from gmcpt.gan.weights import DEFAULT_WEIGHTS, load_generator, weights_path

    path = weights_path(DEFAULT_WEIGHTS)
    if not path.is_file():
        pytest.skip(f"no shipped weights at {path} yet")
    generator, meta = load_generator(DEFAULT_WEIGHTS)   # checks the sha256
    assert meta["command"].startswith("python -m gmcpt train") and meta["dataset"]["version"] >= 1
    assert path.stat().st_size < 5e6


def test_gan_pawnnm_runs_end_to_end():
    from gmcpt.completion import complete
    from gmcpt.gan.weights import DEFAULT_WEIGHTS, weights_path
    from tests.conftest import synthetic_frame

    if not weights_path(DEFAULT_WEIGHTS).is_file():
        pytest.skip("no shipped weights yet")
    frame, clean = synthetic_frame(32, 32)
    result = complete(frame, "gan_pawnnm")
    assert result.image.shape == (32, 32, 3) and np.isfinite(result.image).all()
