"""The training patch sampler and dataset examples as sparse frames.

The network's inputs are :mod:`gmcpt.gan.inputs`'s (shared with inference). Training draws a fresh
random mask per crop at a rate drawn from ``rate_range``, over the dataset's full-frame 16-spp render
(the same per-pixel estimator the product uses for the pixels it traces).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from ..frame import SparseFrame
from ..image.domain import WorkingDomain, frame_coverage
from ..io.examples import load_example
from .inputs import SCALE, feature_stack, working_std


def example_frame(example: dict) -> SparseFrame:
    """The product-identical sparse frame stored in a dataset example."""
    return SparseFrame(radiance=example["radiance"], mask=example["mask"].astype(bool), variance=example["variance"],
                       albedo=example["albedo"], normal=example["normal"], depth=example["depth"],
                       visibility=example["visibility"], spp=int(example["meta"]["spp"]),
                       coverage=example.get("coverage"))


class TrainingBatch(NamedTuple):
    """Crops of one training step, each (B, C, c, c)."""

    radiance: torch.Tensor     # sparse working-domain radiance / 255
    features: torch.Tensor
    target: torch.Tensor       # reference, working domain / 255


class PatchSampler:
    """Random training crops from dataset examples, with fresh masks.

    Each crop comes from a scene drawn uniformly, or with ``probabilities`` (one per path) where given.
    Each scene is kept in memory as one (16, H, W) array: reference (3) and
    full-frame noisy radiance (3) in the working domain / 255, noise std (1),
    albedo (3), normal (3), depth, visibility and coverage. Masks are uniformly random, the paper's
    (a generator trained on the product's placements too scored no better: docs/experiments.md).
    """

    def __init__(self, paths: list[Path], domain: WorkingDomain = WorkingDomain(), crop: int = 64,
                 rate_range: tuple[float, float] = (0.15, 0.5), probabilities: list[float] | None = None):
        if not paths:
            raise ValueError("no training examples")
        if probabilities is not None and len(probabilities) != len(paths):
            raise ValueError(f"{len(probabilities)} probabilities for {len(paths)} training examples")
        self.crop, self.rate_range = crop, rate_range
        # None: uniform over the scenes, drawn as before there were weights (the same random stream)
        self.probabilities = None if probabilities is None else np.asarray(probabilities) / np.sum(probabilities)
        self.scenes = []
        for path in paths:
            example = load_example(path)
            height, width = example["reference"].shape[:2]
            if min(height, width) < crop:  # else the first batch fails with numpy's "high <= 0"
                raise ValueError(f"the training crops are {crop} px, {path} is {width}x{height}: build the dataset "
                                 f"at --res {crop} or more, or train with --set train.crop={min(height, width)}")
            traced = np.ones(example["full_radiance"].shape[:2], bool)
            full = dataclasses.replace(example_frame(example), radiance=example["full_radiance"], mask=traced,
                                       variance=example["full_variance"])
            factor = domain.frame_factor(full)
            parts = [domain.forward(example["reference"], factor) / SCALE,
                     domain.forward(full.radiance, factor) / SCALE,
                     working_std(domain, full.radiance, full.variance, factor, traced)[..., None],
                     example["albedo"], example["normal"], example["depth"][..., None],
                     example["visibility"][..., None], frame_coverage(full)[..., None]]
            # channels first, so that a batch of crops is in the network's layout without a transposed copy
            self.scenes.append(np.ascontiguousarray(np.moveaxis(np.concatenate(parts, -1, dtype=np.float32), -1, 0)))

    def batch(self, rng: np.random.Generator, size: int, use_variance: bool, use_coverage: bool = False
              ) -> TrainingBatch:
        """``size`` random crops with fresh masks (radiance and target (B, 3, c, c), features (B, F, c, c))."""
        crops = []
        for _ in range(size):
            index = (rng.integers(len(self.scenes)) if self.probabilities is None
                     else rng.choice(len(self.scenes), p=self.probabilities))
            scene = self.scenes[index]
            y = rng.integers(scene.shape[1] - self.crop + 1)
            x = rng.integers(scene.shape[2] - self.crop + 1)
            crop = scene[:, y:y + self.crop, x:x + self.crop]
            if rng.random() < 0.5:
                crop = crop[..., ::-1]
            crops.append(crop)
        data = np.stack(crops)
        rates = rng.uniform(*self.rate_range, size=(size, 1, 1))
        mask = rng.random((size, self.crop, self.crop)) < rates
        radiance = data[:, 3:6] * mask[:, None]
        std = data[:, 6] * mask if use_variance else None
        features = feature_stack(mask, data[:, 7:10], data[:, 10:13], data[:, 13], data[:, 14], std,
                                 data[:, 15] if use_coverage else None, axis=1)
        return TrainingBatch(torch.from_numpy(radiance), torch.from_numpy(features),
                             torch.from_numpy(np.ascontiguousarray(data[:, 0:3])))
