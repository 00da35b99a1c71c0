"""The generator's network on OpenVINO, the CPU inference runtime it runs on by default.

The network proper (:meth:`~gmcpt.gan.model.Generator.correction`: the numpy fill stays outside the graph
and comes in as an input) is converted once per weights file, with a free height and width so one model
serves every frame size, and kept on disk as OpenVINO IR (``$GMCPT_CACHE`` or ``~/.cache/gmcpt``, folder
``generators``) under a name made of the weights file's sha256, the model code's and OpenVINO's version: a
new process reads it in a tenth of a second instead of converting for seconds. Compiled networks live as
long as the process. It runs in bfloat16 where :func:`gmcpt.device.generator_precision` says so, as the
PyTorch path does. Where OpenVINO is missing or fails, :func:`cpu_network` says so in one line on stderr,
once, and returns None: the caller runs the generator in PyTorch. ``$GMCPT_GENERATOR_RUNTIME`` ``torch``
keeps PyTorch (training and CUDA always use it).
"""
from __future__ import annotations

import functools
import glob
import hashlib
import os
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import torch

from ..device import AUTO
from ..errors import BadValue
from ..files import cache_folder
from . import model as model_module
from .model import Generator

RUNTIME_ENV = "GMCPT_GENERATOR_RUNTIME"
RUNTIMES = ("openvino", "torch")
#: OpenVINO's names for :func:`gmcpt.device.generator_precision`'s
PRECISION_HINTS = {"float32": "f32", "bfloat16": "bf16"}
INPUT_NAMES = ("radiance", "features", "fill")


def wanted_runtime() -> str:
    """``$GMCPT_GENERATOR_RUNTIME``: ``openvino`` (also :data:`~gmcpt.device.AUTO`, the default) or ``torch``."""
    wanted = os.environ.get(RUNTIME_ENV) or AUTO
    if wanted not in (AUTO, *RUNTIMES):
        raise BadValue(f"generator runtime {wanted!r}: use {AUTO}, {' or '.join(RUNTIMES)}")
    return "openvino" if wanted == AUTO else wanted


def cache_dir() -> Path:
    return cache_folder("generators")


class Correction(torch.nn.Module):
    """A generator's :meth:`~gmcpt.gan.model.Generator.correction` on (1, H, W, C) arrays, the module that is
    converted, so that the channels-last tensors the inputs are built as go in without a copy."""

    def __init__(self, generator: Generator):
        super().__init__()
        self.generator = generator

    def forward(self, radiance: torch.Tensor, features: torch.Tensor, fill: torch.Tensor) -> torch.Tensor:
        planes = (tensor.permute(0, 3, 1, 2) for tensor in (radiance, features, fill))
        return self.generator.correction(*planes).permute(0, 2, 3, 1)


def model_path(weights_file: Path) -> Path:
    """Where the converted network of ``weights_file`` is kept: named by the weights' and the code's hashes."""
    import openvino

    code = hashlib.sha256(Path(model_module.__file__).read_bytes() + Path(__file__).read_bytes()).hexdigest()
    weights = hashlib.sha256(weights_file.read_bytes()).hexdigest()
    return cache_dir() / f"{weights_file.stem}-{weights[:16]}-{code[:8]}-ov{openvino.get_version().split('-')[0]}.xml"


def export(generator: Generator, path: Path) -> None:
    """Convert ``generator``'s network with a free height and width and write it to ``path`` (.xml and .bin)."""
    import openvino

    channels = (3, generator.config.feature_channels, 3)
    example = tuple(torch.zeros(1, 16, 16, count) for count in channels)
    shapes = [(name, [1, -1, -1, count]) for name, count in zip(INPUT_NAMES, channels)]
    with warnings.catch_warnings():  # the tracer's notes on constants it folds: nothing a user can act on
        warnings.simplefilter("ignore")
        network = openvino.convert_model(Correction(generator).eval(), example_input=example, input=shapes)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=path.parent) as folder:  # .bin then .xml renamed in: never half a model
        written = Path(folder) / path.name
        openvino.save_model(network, written, compress_to_fp16=False)
        os.replace(written.with_suffix(".bin"), path.with_suffix(".bin"))
        os.replace(written, path)
    weights_name = path.name.rsplit("-", 3)[0]  # the older conversions of weights of that name: retrained, or old code
    for older in path.parent.glob(f"{glob.escape(weights_name)}-*"):
        if older.stem != path.stem and older.stem.count("-") == path.stem.count("-"):
            older.unlink(missing_ok=True)


class CpuNetwork:
    """The compiled network: ``network(radiance, features, fill)`` -> the correction, all (1, H, W, C) float32."""

    def __init__(self, compiled):
        self.compiled = compiled

    def __call__(self, radiance: np.ndarray, features: np.ndarray, fill: np.ndarray) -> np.ndarray:
        request = self.compiled.create_infer_request()  # one per call: callers may run frames on several threads
        return request.infer([radiance, features, fill], share_inputs=True)[0]


def compile_network(generator: Generator, weights_file: Path, precision: str, threads: int) -> CpuNetwork:
    """The network of ``weights_file`` compiled for the CPU, converted first where no usable copy is on disk."""
    import openvino

    core, path = openvino.Core(), model_path(weights_file)
    config = {"INFERENCE_PRECISION_HINT": PRECISION_HINTS[precision], "INFERENCE_NUM_THREADS": threads,
              "PERFORMANCE_HINT": "LATENCY"}
    if path.is_file():
        try:
            return CpuNetwork(core.compile_model(core.read_model(path), "CPU", config))
        except RuntimeError:  # a truncated or foreign file: converted again below
            pass
    export(generator, path)
    return CpuNetwork(core.compile_model(core.read_model(path), "CPU", config))


@functools.cache
def warn_once(reason: str) -> None:
    print(f"warning: the generator runs in PyTorch: {reason}", file=sys.stderr)


@functools.lru_cache(maxsize=8)
def _cached_network(weights_file: Path, modified: float, precision: str, threads: int, generator: Generator
                    ) -> CpuNetwork | None:
    try:
        return compile_network(generator, weights_file, precision, threads)
    except ImportError:
        warn_once("OpenVINO is not installed (pip install openvino)")
    except Exception as error:  # refused the model or the settings: PyTorch runs it instead
        warn_once(f"OpenVINO failed ({type(error).__name__}: {' '.join(str(error).split())[:160]})")
    return None


def cpu_network(generator: Generator, weights_file: str | Path, precision: str, threads: int) -> CpuNetwork | None:
    """``generator`` (loaded from ``weights_file``) compiled on OpenVINO for ``threads`` threads in ``precision``,
    kept for the process; None where ``$GMCPT_GENERATOR_RUNTIME`` is ``torch`` or OpenVINO is unusable."""
    if wanted_runtime() == "torch":
        return None
    weights_file = Path(weights_file).resolve()
    return _cached_network(weights_file, weights_file.stat().st_mtime, precision, threads, generator)
