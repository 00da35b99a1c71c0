"""Procedural training data for the GAN pre-completion.

:mod:`~gmcpt.dataset.scenes` turns a seed into a Mitsuba scene,
:mod:`~gmcpt.dataset.build` renders references and product-identical sparse
inputs into seeded, versioned ``.npz`` files (their format: :mod:`gmcpt.io.examples`),
:mod:`~gmcpt.cli.dataset` is ``python -m gmcpt dataset``.
"""
from ..io.examples import example_path, list_examples, load_example
from .build import DATASET_VERSION, SPLIT_SEED_BASE, DatasetSpec, SplitSpec, build, split_of

__all__ = ["DATASET_VERSION", "SPLIT_SEED_BASE", "DatasetSpec", "SplitSpec", "build", "example_path",
           "list_examples", "load_example", "split_of"]
