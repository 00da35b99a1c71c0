"""The training examples' files: one seeded ``.npz`` a scene, ``ROOT/<split>/<seed:07d>.npz``, its arrays and a
``meta`` JSON entry (how :mod:`gmcpt.dataset.build` renders them, and what each array holds, is said there).

Here, so that the GAN's training (:mod:`gmcpt.gan.data`, :mod:`gmcpt.gan.train`) reads the examples without
importing the dataset builder, which imports the renderer (``tests/test_layers.py``).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .files import atomic_output

ARRAY_KEYS = ("reference", "radiance", "mask", "variance", "albedo", "normal", "depth", "visibility",
              "full_radiance", "full_variance", "coverage")


def example_path(root: str | Path, split: str, seed: int) -> Path:
    return Path(root) / split / f"{seed:07d}.npz"


def list_examples(root: str | Path, split: str) -> list[Path]:
    """Sorted dataset files of one split."""
    return sorted((Path(root) / split).glob("[0-9]*.npz"))


def save_example(path: Path, example: dict) -> None:
    """Write atomically (temporary name, then rename)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as temporary:
        np.savez_compressed(temporary, meta=np.array(json.dumps(example["meta"])), **example["arrays"])


def load_example(path: str | Path) -> dict:
    """``{"meta": dict, **arrays}`` of one dataset file."""
    with np.load(path) as data:
        example = {key: data[key] for key in ARRAY_KEYS if key in data}
        example["meta"] = json.loads(str(data["meta"]))
    return example
