"""The generator's network converted for OpenVINO (:mod:`gmcpt.gan.runtime`): the one step of CPU inference that
needs PyTorch, run once per weights file.

What is converted is :meth:`~gmcpt.gan.model.Generator.correction` on (1, H, W, C) inputs with a free height and
width, so one model serves every frame size; the numpy fill stays outside the graph and comes in as an input.
Beside the model (``.xml``, ``.bin``) a ``.json`` records the inputs it takes (read back as
:class:`gmcpt.gan.runtime.NetworkInputs`).
"""
from __future__ import annotations

import glob
import json
import os
import tempfile
import warnings
from pathlib import Path

import torch

from .model import Generator

INPUT_NAMES = ("radiance", "features", "fill")


class Correction(torch.nn.Module):
    """A generator's :meth:`~gmcpt.gan.model.Generator.correction` on (1, H, W, C) arrays, the module that is
    converted, so that channels-last arrays go in without a copy."""

    def __init__(self, generator: Generator):
        super().__init__()
        self.generator = generator

    def forward(self, radiance: torch.Tensor, features: torch.Tensor, fill: torch.Tensor) -> torch.Tensor:
        planes = (tensor.permute(0, 3, 1, 2) for tensor in (radiance, features, fill))
        return self.generator.correction(*planes).permute(0, 2, 3, 1)


def export(generator: Generator, path: Path) -> None:
    """Convert ``generator``'s network with a free height and width and write it to ``path`` (.xml, .bin and the
    .json of its inputs); older conversions of weights of the same name go."""
    import openvino

    channels = (3, generator.config.feature_channels, 3)
    example = tuple(torch.zeros(1, 16, 16, count) for count in channels)
    shapes = [(name, [1, -1, -1, count]) for name, count in zip(INPUT_NAMES, channels)]
    with warnings.catch_warnings():  # the tracer's notes on constants it folds: nothing a user can act on
        warnings.simplefilter("ignore")
        network = openvino.convert_model(Correction(generator).eval(), example_input=example, input=shapes)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=path.parent) as folder:  # the .xml renamed in last: never half a model
        written = Path(folder) / path.name
        openvino.save_model(network, written, compress_to_fp16=False)
        inputs = {"use_variance": generator.config.use_variance, "use_coverage": generator.config.use_coverage,
                  "multiple": generator.multiple}
        written.with_suffix(".json").write_text(json.dumps(inputs))
        for suffix in (".bin", ".json", ".xml"):
            os.replace(written.with_suffix(suffix), path.with_suffix(suffix))
    weights_name = path.name.rsplit("-", 3)[0]  # the older conversions of weights of that name: retrained, or old code
    for older in path.parent.glob(f"{glob.escape(weights_name)}-*"):
        if older.stem != path.stem and older.stem.count("-") == path.stem.count("-"):
            older.unlink(missing_ok=True)
