"""Training loop: configs as data, checkpoints and resume, curves, export.

A config (``configs/cpu.json``, ``configs/gpu.json`` or any JSON file) has four
sections: ``train`` (:class:`TrainConfig`), ``generator``
(:class:`~gmcpt.gan.model.GeneratorConfig`), ``critic``
(:class:`~gmcpt.gan.model.CriticConfig`) and ``loss``
(:class:`~gmcpt.gan.losses.LossWeights`). A key left out takes its dataclass
default, and the defaults are the ``cpu`` preset; keys of options measured and
not adopted, which older weights files and checkpoints record, are dropped on
reading (:mod:`gmcpt.gan.retired`).

Each step draws a batch of random crops with fresh masks, updates the WGAN-GP
critic every ``critic_every`` steps (from ``critic_start``) and the generator
with the hybrid loss. The run stops after ``steps`` steps, so the same config
and seed give the same schedule; a wall-clock deadline (``gmcpt train --minutes``)
stops it earlier, after the last step that fits, and a later run resumes there.
``OUT/checkpoint.pt`` is written every ``checkpoint_every`` steps (models,
optimisers, RNG states, history) and a run restarted on the same ``OUT``
resumes from it. ``OUT/curves.png`` plots
the L1, L2 and Wasserstein distances (paper Fig. 4) and the validation PSNR.

Under ``torchrun`` the ranks train data-parallel (:mod:`gmcpt.gan.distributed`):
``batch`` crops per rank and step, rank 0 validates, logs and checkpoints.
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np
import torch

from ..image.domain import WorkingDomain
from ..io.examples import list_examples, load_example
from ..io.files import atomic_output
from ..seeds import TRAINING_RANK_STEP
from . import distributed
from .distributed import Ranks
from .losses import (FixedFeatureExtractor, LossWeights, critic_loss, gradient_penalty, hybrid_loss, l2_loss,
                     wasserstein_distance)
from .model import Critic, CriticConfig, Generator, GeneratorConfig, parameter_count
from .retired import drop_retired

CONFIG_DIR = Path(__file__).resolve().parent / "configs"


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation settings (the defaults are the shipped ``cpu`` preset).

    Attributes
    ----------
    dataset : dataset folder (``train`` and ``val`` splits), or several (a list): their examples are
        pooled, e.g. the procedural set and one of real scenes (:mod:`gmcpt.dataset.real`).
    dataset_weights : with several datasets, the share of the crops drawn from each (normalised);
        empty: each scene equally likely, so in proportion to the datasets' sizes.
    init : start the generator from these weights (a shipped name or a ``.pt`` file) instead of
        random ones: fine-tuning. Its generator config must be this one's; a checkpoint still wins.
    steps : generator updates.
    batch, crop : crops per step and their side in pixels.
    rate_range : sampling rates drawn per crop.
    lr_g, lr_d : Adam learning rates (cosine decay to 5% over the run).
    critic_every : update the critic every this many steps (1: every step).
    critic_start : first step with the critic (and the texture term).
    seed : seeds torch and the batch sampler.
    threads : torch CPU threads (0: torch's default).
    eval_every, checkpoint_every : in steps.
    max_train_scenes : use only the first N training scenes of each dataset (0: all).
    device : torch device of the models and the batches.
    """

    dataset: str | tuple[str, ...] = "data/procedural"
    dataset_weights: tuple[float, ...] = ()
    init: str = ""
    steps: int = 4000
    batch: int = 8
    crop: int = 64
    rate_range: tuple[float, float] = (0.15, 0.5)
    lr_g: float = 1e-3
    lr_d: float = 3e-4
    critic_every: int = 4
    critic_start: int = 0
    seed: int = 1
    threads: int = 1
    eval_every: int = 250
    checkpoint_every: int = 250
    max_train_scenes: int = 300
    device: str = "cpu"

    @property
    def datasets(self) -> tuple[str, ...]:
        return (self.dataset,) if isinstance(self.dataset, str) else tuple(self.dataset)

    def __post_init__(self):
        if not self.datasets:
            raise ValueError("train.dataset names no folder")
        if self.dataset_weights and (len(self.dataset_weights) != len(self.datasets)
                                     or min(self.dataset_weights) < 0 or sum(self.dataset_weights) <= 0):
            raise ValueError(f"train.dataset_weights must be {len(self.datasets)} non-negative numbers, not all 0 "
                             f"(one per dataset), got {list(self.dataset_weights)}")


@dataclass(frozen=True)
class FullConfig:
    train: TrainConfig
    generator: GeneratorConfig
    critic: CriticConfig
    loss: LossWeights

    def to_dict(self) -> dict:
        return {"train": asdict(self.train), "generator": self.generator.to_dict(),
                "critic": self.critic.to_dict(), "loss": self.loss.to_dict()}


def _build(cls, section: str, data: dict):
    data = drop_retired(section, data)
    known = {f.name for f in fields(cls)}
    unknown = set(data) - known
    if unknown:
        raise ValueError(f"unknown {cls.__name__} keys: {', '.join(sorted(unknown))}")
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


def load_config(name_or_path: str, overrides: dict | None = None) -> FullConfig:
    """A preset name (``cpu``, ``gpu``) or a JSON path; ``overrides`` maps ``section.key`` to a value."""
    path = Path(name_or_path)
    if not path.suffix:
        path = CONFIG_DIR / f"{name_or_path}.json"
    data = json.loads(path.read_text())
    for dotted, value in (overrides or {}).items():
        section, key = dotted.split(".", 1)
        data.setdefault(section, {})[key] = value
    return config_from_dict(data)


def config_from_dict(data: dict) -> FullConfig:
    """A config from its four sections; keys left out take their defaults, retired keys are dropped
    (:mod:`gmcpt.gan.retired`)."""
    return FullConfig(train=_build(TrainConfig, "train", data.get("train", {})),
                      generator=_build(GeneratorConfig, "generator", data.get("generator", {})),
                      critic=_build(CriticConfig, "critic", data.get("critic", {})),
                      loss=_build(LossWeights, "loss", data.get("loss", {})))


def validate(generator: Generator, examples: list[dict], domain: WorkingDomain) -> dict:
    """Mean PSNR (tonemapped sRGB) of the generator alone on stored product frames, at their dataset exposure."""
    from ..image.metrics import psnr
    from .data import example_frame
    from .infer import precomplete

    generator.eval()
    scores = []
    for example in examples:
        working, factor = precomplete(generator, example_frame(example), domain)
        scores.append(psnr(domain.inverse(working, factor), example["reference"]))
    generator.train()
    return {"val_psnr": float(np.mean(scores)), "val_psnr_each": [round(s, 3) for s in scores]}


def interp_baseline(examples: list[dict]) -> float:
    """Mean PSNR of the feature-guided fill alone (the ``interp`` method, :func:`gmcpt.image.fills.interpolate`)."""
    from ..image.fills import interpolate
    from ..image.metrics import psnr
    from .data import example_frame

    return float(np.mean([psnr(interpolate(example_frame(e)), e["reference"]) for e in examples]))


def plot_curves(history: list[dict], path: Path, title: str = "") -> None:
    """L2, L1 and Wasserstein distance per step (smoothed), and validation PSNR, as one PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 4, figsize=(16, 3.4))
    for axis, key, label in zip(axes, ("l2", "l1", "wdist"), ("L2 distance", "L1 distance", "Wasserstein distance")):
        steps = np.array([h["step"] for h in history if key in h])
        values = np.array([h[key] for h in history if key in h], float)
        axis.plot(steps, values, color="0.8", lw=0.5)
        if len(values) >= 20:
            kernel = np.ones(20) / 20
            axis.plot(steps[19:], np.convolve(values, kernel, mode="valid"), color="C0")
        axis.set_title(label)
        axis.set_xlabel("step")
        if key != "wdist":
            axis.set_yscale("log")
    val = [(h["step"], h["val_psnr"]) for h in history if "val_psnr" in h]
    if val:
        axes[3].plot(*zip(*val), "o-", color="C1", label="gan")
        base = [h["interp_psnr"] for h in history if "interp_psnr" in h]
        if base:
            axes[3].axhline(base[-1], color="0.5", ls="--", label="interp")
        axes[3].legend()
    axes[3].set_title("validation PSNR (dB)")
    axes[3].set_xlabel("step")
    figure.suptitle(title)
    figure.tight_layout()
    with atomic_output(path) as temporary:
        figure.savefig(temporary, dpi=90)
    plt.close(figure)


class Trainer:
    """Holds models, optimisers, data and history; :meth:`run` trains to ``steps``.

    ``ranks`` (:func:`gmcpt.gan.distributed.from_environment`, its process group
    started) makes this one rank of a data-parallel run; ``quiet`` hides the progress bar.
    """

    def __init__(self, config: FullConfig, out: str | Path, say=print, ranks: Ranks = Ranks(), quiet: bool = False):
        from .data import PatchSampler

        self.config, self.out, self.ranks, self.quiet = config, Path(out), ranks, quiet
        self.say = say if ranks.main else (lambda message: None)
        cfg = config.train
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        torch.manual_seed(cfg.seed)
        self.device = torch.device(distributed.start(ranks, cfg.device))
        self.domain = WorkingDomain()
        self.generator = Generator(config.generator).to(self.device)
        self.critic = Critic(config.generator.feature_channels, config.critic).to(self.device)
        self.model = distributed.wrap(self.generator, ranks)  # the generator as the training step calls it
        if ranks.distributed:  # same initial weights on every rank, then each rank's own random stream
            torch.manual_seed(cfg.seed + TRAINING_RANK_STEP * ranks.rank)
        self.extractor = FixedFeatureExtractor().to(self.device)
        self.opt_g = torch.optim.Adam(self.generator.parameters(), lr=cfg.lr_g, betas=(0.9, 0.99))
        self.opt_d = torch.optim.Adam(self.critic.parameters(), lr=cfg.lr_d, betas=(0.5, 0.9))
        if cfg.init:
            self._load_init(cfg.init)
        groups = []  # the training files of each dataset
        for dataset in cfg.datasets:
            paths = list_examples(dataset, "train")
            if cfg.max_train_scenes:
                if len(paths) < cfg.max_train_scenes:
                    raise ValueError(f"{dataset} has {len(paths)} training scenes, the config asks for "
                                     f"{cfg.max_train_scenes}; finish the dataset build first")
                paths = paths[:cfg.max_train_scenes]
            if not paths:
                raise ValueError(f"{dataset} has no training scenes; build it first")
            groups.append(paths)
        train_paths = [path for paths in groups for path in paths]
        self.train_seeds = [[int(p.stem) for p in paths] for paths in groups]
        shards = [distributed.shard(paths, ranks) for paths in groups]
        # a scene's probability: its dataset's share over that dataset's scene count
        probabilities = ([w / sum(cfg.dataset_weights) / len(shard) for w, shard in zip(cfg.dataset_weights, shards)
                          for _ in shard] if cfg.dataset_weights else None)
        self.sampler = PatchSampler([p for shard in shards for p in shard], self.domain, cfg.crop, cfg.rate_range,
                                    probabilities)
        self.val = ([load_example(p) for dataset in cfg.datasets for p in list_examples(dataset, "val")]
                    if ranks.main else [])
        self.rng = np.random.default_rng(distributed.seed_sequence(cfg.seed, ranks))
        self.step, self.history, self.seconds, self.stopped_early = 0, [], 0.0, False
        self.say(f"generator {parameter_count(self.generator) / 1e6:.3f} M parameters, critic "
                 f"{parameter_count(self.critic) / 1e6:.3f} M; {len(train_paths)} training scenes, {len(self.val)} val"
                 + (f"; {ranks.world} processes, {cfg.batch} crops each a step" if ranks.distributed else ""))

    def _load_init(self, name: str) -> None:
        """Start the generator from shipped weights (``train.init``); its architecture must be this config's."""
        from .weights import load_generator

        try:
            source, _ = load_generator(name)
        except Exception as error:  # GmcptError: one line already
            raise ValueError(f"train.init: {error}") from None
        if source.config.to_dict() != self.generator.config.to_dict():
            raise ValueError(f"train.init: {name} has another generator config than this run's; "
                             "use the config it was trained with")
        self.generator.load_state_dict(source.state_dict())

    # ---------------------------------------------------------------- checkpoints
    @property
    def checkpoint_path(self) -> Path:
        return self.out / "checkpoint.pt"

    def save_checkpoint(self) -> None:
        """Rank 0 writes the checkpoint; with several ranks every rank takes part (their random states)."""
        rngs = distributed.gather((torch.get_rng_state(), self.rng.bit_generator.state), self.ranks)
        if not self.ranks.main:
            return
        state = {"step": self.step, "seconds": self.seconds, "config": json.dumps(self.config.to_dict()),
                 "generator": self.generator.state_dict(), "critic": self.critic.state_dict(),
                 "opt_g": self.opt_g.state_dict(), "opt_d": self.opt_d.state_dict(),
                 "torch_rng": rngs[0][0], "numpy_rng": json.dumps(rngs[0][1]), "history": json.dumps(self.history)}
        if self.ranks.distributed:
            state.update(world_size=self.ranks.world, rank_torch_rng=[r[0] for r in rngs],
                         rank_numpy_rng=json.dumps([r[1] for r in rngs]))
        self.out.mkdir(parents=True, exist_ok=True)
        with atomic_output(self.checkpoint_path) as temporary:
            torch.save(state, temporary)

    def load_checkpoint(self) -> bool:
        if not self.checkpoint_path.is_file():
            return False
        state = torch.load(self.checkpoint_path, map_location=self.device, weights_only=True)
        stored = config_from_dict(json.loads(state["config"])).to_dict()  # keys added since: defaults
        if json.loads(json.dumps(stored)) != json.loads(json.dumps(self.config.to_dict())):
            raise ValueError(f"{self.checkpoint_path} was made with another config; use a new --out")
        world = int(state.get("world_size", 1))
        if world != self.ranks.world:
            raise ValueError(f"{self.checkpoint_path} was made by {world} process(es), this run has "
                             f"{self.ranks.world}; resume with torchrun --nproc_per_node {world} or use a new --out")
        self.generator.load_state_dict(state["generator"])
        self.critic.load_state_dict(state["critic"])
        self.opt_g.load_state_dict(state["opt_g"])
        self.opt_d.load_state_dict(state["opt_d"])
        if self.ranks.distributed:
            torch.set_rng_state(state["rank_torch_rng"][self.ranks.rank].cpu())
            self.rng.bit_generator.state = json.loads(state["rank_numpy_rng"])[self.ranks.rank]
        else:
            torch.set_rng_state(state["torch_rng"].cpu())
            self.rng.bit_generator.state = json.loads(state["numpy_rng"])
        self.step, self.seconds = int(state["step"]), float(state["seconds"])
        self.history = json.loads(state["history"])
        self.say(f"resumed from {self.checkpoint_path} at step {self.step}")
        return True

    # ---------------------------------------------------------------- steps
    def _learning_rate_scale(self) -> float:
        progress = self.step / max(1, self.config.train.steps)
        return 0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * progress))

    def train_step(self) -> dict:
        cfg, weights = self.config.train, self.config.loss
        for optimizer, base in ((self.opt_g, cfg.lr_g), (self.opt_d, cfg.lr_d)):
            for group in optimizer.param_groups:
                group["lr"] = base * self._learning_rate_scale()
        radiance, features, target = (
            t.to(self.device) for t in self.sampler.batch(self.rng, cfg.batch, self.config.generator.use_variance,
                                                          self.config.generator.use_coverage))
        fake = self.model(radiance, features)
        record = {}
        adversarial = self.step >= cfg.critic_start
        if adversarial and self.step % cfg.critic_every == 0:
            real_score, fake_score = self.critic(target, features), self.critic(fake.detach(), features)
            penalty = gradient_penalty(self.critic, target, fake.detach(), features)
            loss_d = critic_loss(real_score, fake_score) + weights.gp_lambda * penalty
            self.opt_d.zero_grad(set_to_none=True)
            loss_d.backward()
            distributed.average_gradients(self.critic, self.ranks)
            self.opt_d.step()
            record.update(wdist=float(wasserstein_distance(real_score, fake_score).detach()), gp=float(penalty.detach()))
        self.critic.requires_grad_(False)
        fake_score = self.critic(fake, features) if adversarial and weights.alpha else None
        loss_g, terms = hybrid_loss(fake, target, fake_score, self.extractor(fake), self.extractor(target), weights)
        self.critic.requires_grad_(True)
        self.opt_g.zero_grad(set_to_none=True)
        loss_g.backward()
        self.opt_g.step()
        record.update(terms, loss=float(loss_g.detach()), l2=float(l2_loss(fake.detach(), target)))
        return record

    def _out_of_time(self, deadline: float | None, started: float, steps: int) -> bool:
        """True if another step, as long as this run's steps have been on average, would end after
        ``deadline`` (:func:`time.monotonic`); every rank takes rank 0's decision."""
        if deadline is None:
            return False
        now = time.monotonic()
        late = now + (now - started) / max(1, steps) * (steps > 0) > deadline
        return bool(distributed.gather(late, self.ranks)[0])

    def run(self, deadline: float | None = None) -> dict:
        """Train to ``steps``, or until the next step would end after ``deadline`` (a
        :func:`time.monotonic` time); either way the last step is validated and checkpointed."""
        from ..runtime.progress import Progress

        cfg = self.config.train
        self.load_checkpoint()
        if not any("interp_psnr" in h for h in self.history) and self.val:
            self.history.append({"step": self.step, "interp_psnr": interp_baseline(self.val)})
        started, first = time.monotonic(), self.step
        with Progress(cfg.steps, "train", unit="step", say=self.say, quiet=self.quiet or not self.ranks.main,
                      initial=self.step, log_every=0) as bar:  # log lines: the validation steps below
            while self.step < cfg.steps:
                if self._out_of_time(deadline, started, self.step - first):
                    self.stopped_early = True
                    self._finish_early(first)
                    break
                start = time.perf_counter()
                record = self.train_step()
                self.step += 1
                self.seconds += time.perf_counter() - start
                self.history.append({"step": self.step, **{k: round(v, 6) for k, v in record.items()}})
                bar.update(note=f"l1 {record['l1']:.4f}")
                last = self.step == cfg.steps
                if self.val and (self.step % cfg.eval_every == 0 or last):
                    self.history.append({"step": self.step, **validate(self.generator, self.val, self.domain)})
                    recent = [h for h in self.history[-cfg.eval_every - 1:] if "l1" in h]
                    critic = [h["wdist"] for h in recent if "wdist" in h]  # none before critic_start
                    bar.write(f"step {self.step}/{cfg.steps} ({self.seconds / 60:.1f} min): "
                              f"l1 {np.mean([h['l1'] for h in recent]):.4f} "
                              + (f"wdist {np.mean(critic):.3f} " if critic else "wdist - (critic not started) ")
                              + f"val PSNR {self.history[-1]['val_psnr']:.2f} dB")
                if self.step % cfg.checkpoint_every == 0 or last:
                    self.save_checkpoint()
                    if self.ranks.main:
                        plot_curves(self.history, self.out / "curves.png", f"{self.out.name}")
        if self.ranks.distributed:  # the ranks must agree bit for bit: report what each holds
            self.rank_digests = distributed.gather(
                distributed.weights_digest(self.generator.state_dict(), self.critic.state_dict()), self.ranks)
        if self.ranks.main:
            self.out.mkdir(parents=True, exist_ok=True)
            (self.out / "history.json").write_text(json.dumps(self.history))
        return self.summary()

    def _finish_early(self, first: int) -> None:
        """Validate and checkpoint the last finished step of a run stopped by its deadline."""
        self.say(f"time limit: stopped at step {self.step}/{self.config.train.steps}; rerun to resume")
        if self.step == first:
            return
        if self.val and not any(h.get("step") == self.step and "val_psnr" in h for h in self.history):
            self.history.append({"step": self.step, **validate(self.generator, self.val, self.domain)})
        self.save_checkpoint()
        if self.ranks.main:
            plot_curves(self.history, self.out / "curves.png", f"{self.out.name}")

    def summary(self) -> dict:
        val = [h for h in self.history if "val_psnr" in h]
        base = [h["interp_psnr"] for h in self.history if "interp_psnr" in h]
        summary = {"steps": self.step, "train_seconds": round(self.seconds, 1),
                   "val_psnr": val[-1]["val_psnr"] if val else None, "val_interp_psnr": base[-1] if base else None,
                   "train_scenes": sum(map(len, self.train_seeds)), "val_scenes": len(self.val),
                   "stopped_early": self.stopped_early}
        if self.ranks.distributed:
            summary.update(processes=self.ranks.world, rank_weights_sha256=getattr(self, "rank_digests", None))
        return summary
