"""GAN training: configs (presets, retired options), the patch sampler's inputs, the loop, its command line."""
import json

import numpy as np
import pytest
import torch

from gan_helpers import SMALL, generator_inputs, tiny_dataset
from gmcpt.gan import losses
from gmcpt.gan.model import Generator, GeneratorConfig


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


def test_training_checkpoints_resumes_and_exports(tmp_path, monkeypatch):
    from gmcpt.cli import train
    from gmcpt.gan import names
    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    tiny_dataset(data)
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
    monkeypatch.setattr(names, "WEIGHTS_DIR", tmp_path / "shipped")
    record = train.export(again, "tiny", "python -m gmcpt train ...")
    assert record["dataset"]["version"] == 1 and (tmp_path / "shipped" / "tiny.pt").is_file()


def test_progress_before_the_critic_starts_says_so_without_warnings(tmp_path):
    import warnings

    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    tiny_dataset(data)
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
    from gmcpt.image.domain import WorkingDomain
    from gmcpt.gan.data import PatchSampler
    from gmcpt.gan.inputs import frame_arrays
    from tests.conftest import synthetic_frame

    frame, _ = synthetic_frame(16, 16)
    coverage = np.linspace(0, 1, 256, dtype=np.float32).reshape(16, 16)
    with_buffer = dataclasses.replace(frame, coverage=coverage)
    config = GeneratorConfig(use_coverage=True)
    _, plain, _ = frame_arrays(with_buffer, WorkingDomain(), use_variance=True)
    _, features, _ = frame_arrays(with_buffer, WorkingDomain(), use_variance=True, use_coverage=True)
    assert features.shape[-1] == config.feature_channels == plain.shape[-1] + 1
    assert np.array_equal(features[..., :-1], plain)
    assert np.array_equal(features[..., -1], coverage)
    _, rule, _ = frame_arrays(dataclasses.replace(frame, coverage=None), WorkingDomain(), True, True)
    assert np.array_equal(rule[..., -1], (frame.albedo.max(-1) >= 0.02).astype(np.float32))

    tiny_dataset(tmp_path)
    sampler = PatchSampler(list_examples(tmp_path, "train"), crop=16)
    batch = sampler.batch(np.random.default_rng(0), 4, use_variance=True, use_coverage=True).features
    assert batch.shape[1] == config.feature_channels
    # the tiny dataset's files have no coverage buffer: the 0/1 rule over the crop's albedo channels
    assert torch.equal(batch[:, -1], (batch[:, 1:4].amax(1) >= 0.02).float())
    generator = Generator(dataclasses.replace(SMALL, use_coverage=True))
    radiance, _ = generator_inputs(batch=4)
    assert generator(radiance, batch[:, :generator.config.feature_channels]).shape == (4, 3, 16, 16)


def test_a_batch_holds_each_crop_in_the_networks_layout(tmp_path):
    """Every crop of a batch is one crop of its scene (mirrored or not), channels first, the same in every buffer;
    its radiance only where its mask traced."""
    from gmcpt.dataset import list_examples, load_example
    from gmcpt.gan.data import PatchSampler

    tiny_dataset(tmp_path, count=1, size=16)
    example = load_example(list_examples(tmp_path, "train")[0])
    batch = PatchSampler(list_examples(tmp_path, "train"), crop=16).batch(np.random.default_rng(3), 6, True)
    albedo, normal = (torch.from_numpy(np.moveaxis(example[name], -1, 0)) for name in ("albedo", "normal"))
    flips = 0
    for features, radiance in zip(batch.features, batch.radiance):
        flipped = not torch.equal(features[1:4], albedo)
        flips += flipped
        orient = (lambda image: image.flip(-1)) if flipped else (lambda image: image)
        assert torch.equal(orient(features[1:4]), albedo) and torch.equal(orient(features[4:7]), normal)
        assert torch.equal(orient(features[7]), torch.from_numpy(example["depth"]))
        traced = features[0] > 0
        assert 0 < traced.float().mean() < 1 and torch.all(radiance[:, ~traced] == 0)
        assert torch.all(radiance.amax(0)[traced] > 0)
    assert 0 < flips < len(batch.features)  # both orientations drawn (seed 3)


def test_train_cli_reports_a_missing_dataset(tmp_path, capsys):
    from gmcpt.cli.train import main

    assert main(["--config", "cpu", "--dataset", str(tmp_path / "none"), "--out", str(tmp_path / "r")]) == 2
    assert "python -m gmcpt dataset" in capsys.readouterr().err


def test_presets_load():
    from gmcpt.gan.train import load_config

    cpu, gpu = load_config("cpu"), load_config("gpu")
    assert cpu.train.device == "cpu" and gpu.train.device == "cuda"
    assert cpu.loss == gpu.loss == losses.LossWeights()


TINY = {"train.steps": 1, "train.max_train_scenes": 0, "train.batch": 2, "train.crop": 16, "train.eval_every": 1,
        "train.checkpoint_every": 1, "critic.widths": [8, 8], "generator.widths": [8, 8, 8],
        "generator.encoder_blocks": [1, 1, 1], "generator.condition_width": 4}


#: a run that stops on a deadline, not on a step count
LONG = {"train.steps": 100000, "train.eval_every": 1000, "train.checkpoint_every": 1000}


def test_several_datasets_pool_with_weights_and_export_each(tmp_path, monkeypatch):
    from gmcpt.cli import train
    from gmcpt.gan import names
    from gmcpt.gan.train import Trainer, load_config

    first, second = tmp_path / "procedural", tmp_path / "real"
    tiny_dataset(first, count=2)
    tiny_dataset(second, count=3)
    both = [str(first), str(second)]
    trainer = Trainer(load_config("cpu", {**TINY, "train.dataset": both}), tmp_path / "run", lambda m: None)
    assert trainer.train_seeds == [[0, 1], [0, 1, 2]] and len(trainer.val) == 5
    assert trainer.sampler.probabilities is None   # each scene equally likely, the one-dataset stream
    weighted = Trainer(load_config("cpu", {**TINY, "train.dataset": both, "train.dataset_weights": [1, 3]}),
                       tmp_path / "run2", lambda m: None)
    np.testing.assert_allclose(weighted.sampler.probabilities, [1 / 8] * 2 + [1 / 4] * 3)
    summary = weighted.run()
    assert summary["train_scenes"] == 5
    monkeypatch.setattr(names, "WEIGHTS_DIR", tmp_path / "shipped")
    record = train.export(weighted, "mix", "python -m gmcpt train ...")
    assert [d["path"] for d in record["dataset"]] == both and [d["train_scenes"] for d in record["dataset"]] == [2, 3]
    for bad in ([1], [1, -1], [0, 0]):
        with pytest.raises(ValueError, match="train.dataset_weights must be 2 non-negative numbers"):
            load_config("cpu", {**TINY, "train.dataset": both, "train.dataset_weights": bad})


def test_init_starts_from_the_weights_and_refuses_another_architecture(tmp_path, monkeypatch):
    from gmcpt.cli import train
    from gmcpt.gan import names, weights
    from gmcpt.gan.train import Trainer, load_config

    data = tmp_path / "data"
    tiny_dataset(data)
    monkeypatch.setattr(names, "WEIGHTS_DIR", tmp_path / "shipped")
    source = Trainer(load_config("cpu", {**TINY, "train.dataset": str(data)}), tmp_path / "a", lambda m: None)
    source.run()
    train.export(source, "start", "python -m gmcpt train ...")
    tuned = Trainer(load_config("cpu", {**TINY, "train.dataset": str(data), "train.seed": 5,
                                        "train.init": "start"}), tmp_path / "b", lambda m: None)
    start, _ = weights.load_generator("start")
    for name, tensor in start.state_dict().items():  # the stored (half-precision) weights, exactly
        assert torch.equal(tuned.generator.state_dict()[name], tensor), name
    with pytest.raises(ValueError, match="train.init: start has another generator config"):
        Trainer(load_config("cpu", {**TINY, "train.dataset": str(data), "generator.condition_width": 8,
                                    "train.init": "start"}), tmp_path / "c", lambda m: None)
    with pytest.raises(ValueError, match="train.init: GAN weights not found"):
        Trainer(load_config("cpu", {**TINY, "train.dataset": str(data), "train.init": "nothing"}),
                tmp_path / "d", lambda m: None)


def test_train_cli_pools_datasets_and_reports_a_missing_one(tmp_path, capsys):
    from gmcpt.cli.train import main

    tiny_dataset(tmp_path / "one")
    argv = ["--config", "cpu", "--dataset", str(tmp_path / "one"), "--dataset", str(tmp_path / "two"),
            "--out", str(tmp_path / "r")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: no dataset at") and str(tmp_path / "two") in err and err.count("\n") == 1
    assert main(argv[:2] + ["--dataset", str(tmp_path / "one"), "--init", "nothing", "--out", str(tmp_path / "r"),
                            "--set", "train.max_train_scenes=0"]) == 2
    assert "train.init: GAN weights not found" in capsys.readouterr().err


def test_a_deadline_stops_after_the_last_step_that_fits_checkpoints_and_resumes(tmp_path):
    import time

    from gmcpt.gan.train import Trainer, load_config

    tiny_dataset(tmp_path / "data")
    config = load_config("cpu", {**TINY, **LONG, "train.dataset": str(tmp_path / "data")})
    out = tmp_path / "run"
    assert Trainer(config, out, lambda m: None).run(time.monotonic() - 1)["steps"] == 0   # nothing fits
    first = Trainer(config, out, lambda m: None).run(time.monotonic() + 1.0)
    assert first["stopped_early"] and 0 < first["steps"] < 100000
    history = json.loads((out / "history.json").read_text())
    assert history[-1] == {"step": first["steps"], **{k: v for k, v in history[-1].items() if k != "step"}}
    assert "val_psnr" in history[-1] and (out / "curves.png").is_file()
    resumed = Trainer(config, out, lambda m: None)
    assert resumed.load_checkpoint() and resumed.step == first["steps"]
    assert resumed.run(time.monotonic() + 1.0)["steps"] > first["steps"]


def test_train_cli_minutes_several_datasets_and_export_to_a_path(tmp_path, capsys):
    from gmcpt.cli.train import main
    from gmcpt.gan.weights import load_generator

    for name in ("a", "b"):
        tiny_dataset(tmp_path / name)
    sets = [f"--set={key}={json.dumps(value)}" for key, value in {**TINY, **LONG}.items()]
    argv = ["--config", "cpu", "--dataset", str(tmp_path / "a"), "--dataset", str(tmp_path / "b"), *sets,
            "--out", str(tmp_path / "run"), "--export", str(tmp_path / "w" / "tiny.pt"), "--minutes", "0.05", "-q"]
    assert main(argv) == 0
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert summary["stopped_early"] and summary["train_scenes"] == 4 and summary["val_scenes"] == 4
    generator, metadata = load_generator(tmp_path / "w" / "tiny.pt")
    assert metadata["name"] == "tiny" and [d["path"] for d in metadata["dataset"]] == [str(tmp_path / "a"), str(tmp_path / "b")]
    assert metadata["training"]["steps"] == summary["steps"] > 0
    assert main([*argv[:-3], "--minutes", "0", "-q"]) == 2 and "--minutes must be positive" in capsys.readouterr().err


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the message where torch sees no CUDA")
def test_a_cuda_config_without_cuda_is_one_line(tmp_path, capsys):
    from gmcpt.cli.train import main

    tiny_dataset(tmp_path / "data")
    assert main(["--config", "gpu", "--dataset", str(tmp_path / "data"), "--out", str(tmp_path / "run"), "-q"]) == 2
    error = capsys.readouterr().err.strip()
    assert "torch sees no CUDA" in error and len(error.splitlines()) == 1 and not (tmp_path / "run").exists()


@pytest.mark.cuda
def test_training_steps_run_on_cuda(tmp_path):
    from gmcpt.gan.train import Trainer, load_config

    tiny_dataset(tmp_path / "data")
    config = load_config("gpu", {**TINY, "train.dataset": str(tmp_path / "data"), "train.steps": 3,
                                 "train.critic_start": 0})
    trainer = Trainer(config, tmp_path / "run", lambda m: None)
    assert trainer.run()["steps"] == 3
    assert all(p.is_cuda and torch.isfinite(p).all() for p in trainer.generator.parameters())
    assert all(np.isfinite(h["l1"]) and np.isfinite(h["wdist"]) for h in trainer.history if "l1" in h)
