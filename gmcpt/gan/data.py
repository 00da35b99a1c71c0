"""Network inputs, shared by training and inference, and the training patch sampler.

The generator sees (all in the working domain of :mod:`gmcpt.domain`, divided by 255):

- ``radiance`` (3): sparse demodulated, log-compressed radiance, 0 where not traced;
- ``features``: mask, albedo (3), normal (3), depth, visibility and, when the
  config asks, the standard deviation of each traced pixel's mean (delta
  method, 0 elsewhere, clipped at 1) and the feature pass's coverage.

Training draws a fresh random mask per crop at a rate drawn from
``rate_range``, over the dataset's full-frame 16-spp render (the same
per-pixel estimator the product uses for the pixels it traces).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import NamedTuple

import numpy as np
import torch

from ..domain import WorkingDomain, frame_coverage
from ..frame import SparseFrame

SCALE = 255.0


def feature_stack(mask: np.ndarray, albedo: np.ndarray, normal: np.ndarray, depth: np.ndarray,
                  visibility: np.ndarray, std: np.ndarray | None, coverage: np.ndarray | None = None) -> np.ndarray:
    """(H, W, F) float32 features in the generator's channel order (``std`` and ``coverage`` where given),
    joined in one copy."""
    parts = [mask[..., None], albedo, normal, depth[..., None], visibility[..., None]]
    parts += [extra[..., None] for extra in (std, coverage) if extra is not None]
    return np.concatenate(parts, axis=-1, dtype=np.float32)


def working_std(domain: WorkingDomain, radiance: np.ndarray, variance: np.ndarray, factor: np.ndarray,
                mask: np.ndarray) -> np.ndarray:
    """Standard deviation of traced pixels in the working domain / 255, clipped to [0, 1]."""
    std = np.sqrt(np.maximum(domain.variance(radiance, variance, factor), 0.0)) / SCALE
    return np.where(mask, np.minimum(std, 1.0), 0.0).astype(np.float32)


def frame_inputs(frame: SparseFrame, domain: WorkingDomain, use_variance: bool, use_coverage: bool = False
                 ) -> tuple[torch.Tensor, torch.Tensor, np.ndarray]:
    """(radiance (1, 3, H, W), features (1, F, H, W), factor (H, W, 3)) of a sparse frame."""
    factor = domain.frame_factor(frame)
    working = domain.forward_traced(frame.radiance, factor, frame.mask) / SCALE
    std = working_std(domain, frame.radiance, frame.variance, factor, frame.mask) if use_variance else None
    coverage = frame_coverage(frame) if use_coverage else None
    features = feature_stack(frame.mask, frame.albedo, frame.normal, frame.depth, frame.visibility, std, coverage)
    # (H, W, C) arrays seen as (1, C, H, W) without a copy: channels-last tensors, as the generator runs on a CPU
    as_tensor = lambda array: torch.from_numpy(np.asarray(array, np.float32)).permute(2, 0, 1)[None]  # noqa: E731
    return as_tensor(working), as_tensor(features), factor


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

    Each scene is kept in memory as one (H, W, 16) array: reference (3) and
    full-frame noisy radiance (3) in the working domain / 255, noise std (1),
    albedo (3), normal (3), depth, visibility and coverage. Masks are uniformly random, the paper's
    (a generator trained on the product's placements too scored no better: docs/experiments.md).
    """

    def __init__(self, paths: list[Path], domain: WorkingDomain = WorkingDomain(), crop: int = 64,
                 rate_range: tuple[float, float] = (0.15, 0.5)):
        from ..dataset import load_example

        if not paths:
            raise ValueError("no training examples")
        self.crop, self.rate_range = crop, rate_range
        self.scenes = []
        for path in paths:
            example = load_example(path)
            traced = np.ones(example["full_radiance"].shape[:2], bool)
            full = dataclasses.replace(example_frame(example), radiance=example["full_radiance"], mask=traced,
                                       variance=example["full_variance"])
            factor = domain.frame_factor(full)
            parts = [domain.forward(example["reference"], factor) / SCALE,
                     domain.forward(full.radiance, factor) / SCALE,
                     working_std(domain, full.radiance, full.variance, factor, traced)[..., None],
                     example["albedo"], example["normal"], example["depth"][..., None],
                     example["visibility"][..., None], frame_coverage(full)[..., None]]
            self.scenes.append(np.concatenate(parts, -1).astype(np.float32))

    def batch(self, rng: np.random.Generator, size: int, use_variance: bool, use_coverage: bool = False
              ) -> TrainingBatch:
        """``size`` random crops with fresh masks (radiance and target (B, 3, c, c), features (B, F, c, c))."""
        crops = []
        for _ in range(size):
            scene = self.scenes[rng.integers(len(self.scenes))]
            y = rng.integers(scene.shape[0] - self.crop + 1)
            x = rng.integers(scene.shape[1] - self.crop + 1)
            crop = scene[y:y + self.crop, x:x + self.crop]
            if rng.random() < 0.5:
                crop = crop[:, ::-1]
            crops.append(crop)
        data = np.stack(crops)
        rates = rng.uniform(*self.rate_range, size=(size, 1, 1))
        mask = rng.random(data.shape[:3]) < rates
        radiance = data[..., 3:6] * mask[..., None]
        std = data[..., 6] * mask if use_variance else None
        features = np.stack([feature_stack(mask[i], data[i, ..., 7:10], data[i, ..., 10:13], data[i, ..., 13],
                                           data[i, ..., 14], None if std is None else std[i],
                                           data[i, ..., 15] if use_coverage else None) for i in range(size)])
        to_tensor = lambda a: torch.from_numpy(np.ascontiguousarray(a.transpose(0, 3, 1, 2))).float()  # noqa: E731
        return TrainingBatch(to_tensor(radiance), to_tensor(features), to_tensor(data[..., 0:3]))
