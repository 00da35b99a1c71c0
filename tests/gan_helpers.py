"""Shared by the GAN tests: a small generator config, random network inputs, a tiny dataset."""
import json

import torch

from gmcpt.gan.model import GeneratorConfig

SMALL = GeneratorConfig(widths=(8, 8, 8), encoder_blocks=(1, 1, 1), decoder_blocks=(1, 1), condition_width=4)


def generator_inputs(batch=2, size=16, config=SMALL, seed=0):
    generator = torch.Generator().manual_seed(seed)
    mask = (torch.rand(batch, 1, size, size, generator=generator) < 0.3).float()
    radiance = torch.rand(batch, 3, size, size, generator=generator) * mask
    rest = torch.rand(batch, config.feature_channels - 1, size, size, generator=generator)
    return radiance, torch.cat([mask, rest], 1)


def tiny_dataset(root, count=2, size=24):
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
