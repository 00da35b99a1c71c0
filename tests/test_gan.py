"""GAN pre-completion: model, loss terms, weights I/O, training loop, completion methods."""
import json

import numpy as np
import pytest
import torch

from gmcpt.errors import GmcptError
from gmcpt.gan import losses
from gmcpt.gan.model import Critic, CriticConfig, Generator, GeneratorConfig, ModulatedResBlock

SMALL = GeneratorConfig(widths=(8, 8, 8), encoder_blocks=(1, 1, 1), decoder_blocks=(1, 1), condition_width=4)


def _inputs(batch=2, size=16, config=SMALL, seed=0):
    generator = torch.Generator().manual_seed(seed)
    mask = (torch.rand(batch, 1, size, size, generator=generator) < 0.3).float()
    radiance = torch.rand(batch, 3, size, size, generator=generator) * mask
    rest = torch.rand(batch, config.feature_channels - 1, size, size, generator=generator)
    return radiance, torch.cat([mask, rest], 1)


# ----------------------------------------------------------------------------- model

def test_generator_starts_from_the_smoothed_feature_guided_fill_and_is_small():
    from gmcpt.fills import guided_fill

    generator = Generator()
    assert 0.3e6 < sum(p.numel() for p in generator.parameters()) < 1.0e6  # CPU-sized (docs/design.md section 3: well under 1.5 M)
    radiance, features = _inputs(batch=2, size=24, config=GeneratorConfig())
    out = generator(radiance, features)   # zero-initialised tail: the fill itself
    assert out.shape == radiance.shape
    for i in range(2):
        image = radiance[i].permute(1, 2, 0).numpy()
        aux = features[i].permute(1, 2, 0).numpy()
        expected = guided_fill(image, aux[..., 0] > 0, aux[..., 1:9], keep_samples=False)
        np.testing.assert_allclose(out[i].detach().permute(1, 2, 0).numpy(), expected, atol=1e-6)
    traced = features[:, :1].expand_as(radiance) > 0
    assert (out[traced] != radiance[traced]).float().mean() > 0.1   # traced pixels with like neighbours are averaged too


def _other_than(value):
    """A value of the same JSON type as ``value`` but not equal to it."""
    if isinstance(value, bool):
        return not value
    if isinstance(value, str):
        return value + "_other"
    return [*value, "x"] if isinstance(value, list) else value + 1


def test_stored_configs_with_retired_options_still_read():
    from gmcpt.gan.retired import RETIRED
    from gmcpt.gan.train import config_from_dict, load_config
    from gmcpt.gan.weights import DEFAULT_WEIGHTS, weights_path

    # every retired key at the value that reads as today's behaviour (None: any value)
    stored = {section: {key: 9 if value is None else value for key, value in keys.items()}
              for section, keys in RETIRED.items()}
    assert config_from_dict(stored) == config_from_dict({}) == load_config("cpu")
    generator_config = {**GeneratorConfig().to_dict(), **stored["generator"]}
    assert GeneratorConfig.from_dict(json.loads(json.dumps(generator_config))) == GeneratorConfig()
    # the training config a shipped weights file records
    metadata = json.loads(weights_path(DEFAULT_WEIGHTS).with_suffix(".json").read_text())
    assert config_from_dict(metadata["config"]).generator == GeneratorConfig.from_dict(metadata["generator_config"])
    # a retired option asking for its removed behaviour is refused in one line
    for section, keys in RETIRED.items():
        for key, value in keys.items():
            if value is None:
                continue
            with pytest.raises(ValueError, match=f"{section}.{key} = .* is a retired option") as error:
                config_from_dict({section: {key: _other_than(value)}})
            assert "\n" not in str(error.value)
    with pytest.raises(ValueError, match="unknown TrainConfig keys: steps_"):
        config_from_dict({"train": {"steps_": 1}})


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
    assert cpu.loss == gpu.loss == losses.LossWeights()


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


def test_target_exposure_sets_the_95th_percentile():
    import dataclasses

    from gmcpt.gan.infer import EXPOSURE_TARGET, exposed, target_exposure
    from tests.conftest import synthetic_frame

    frame, _ = synthetic_frame()
    exposure = target_exposure(frame)
    brought = exposed(frame, exposure)
    level = np.percentile(brought.radiance[brought.mask].mean(axis=-1), 95)
    assert level == pytest.approx(EXPOSURE_TARGET, rel=1e-4)
    assert np.allclose(brought.variance, frame.variance * exposure ** 2)
    assert target_exposure(dataclasses.replace(frame, mask=np.zeros_like(frame.mask))) == 1.0


def test_gan_output_follows_the_exposure_of_its_input(tmp_path):
    """The target exposure: a frame 7x brighter completes to a 7x brighter image (same network input)."""
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
