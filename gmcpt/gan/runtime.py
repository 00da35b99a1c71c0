"""The generator's network on OpenVINO, the CPU inference runtime it runs on by default.

The network proper (:meth:`~gmcpt.gan.model.Generator.correction`: the numpy fill stays outside the graph
and comes in as an input) is converted once per weights file (:mod:`gmcpt.gan.export`, in PyTorch) and kept on
disk as OpenVINO IR (``$GMCPT_CACHE`` or ``~/.cache/gmcpt``, folder ``generators``) under a name made of the
weights file's sha256, the model code's and OpenVINO's version. A process that finds it there runs the
generator without importing torch (:func:`precomplete_on_cpu`; the import alone is 6-7 s on 2 cores).
Compiled networks live as long as the process. It runs in bfloat16 where :func:`gmcpt.device.generator_precision`
says so, as the PyTorch path does. Where OpenVINO is missing or fails, :func:`cpu_network` says so in one line
on stderr, once, and returns None: the caller runs the generator in PyTorch. ``$GMCPT_GENERATOR_RUNTIME``
``torch`` keeps PyTorch (training and CUDA always use it).
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..device import AUTO
from ..domain import WorkingDomain
from ..errors import BadValue, GmcptError
from ..files import cache_folder
from ..frame import SparseFrame
from .inputs import exposed, network_arrays, working_image
from .names import checked_weights

RUNTIME_ENV = "GMCPT_GENERATOR_RUNTIME"
RUNTIMES = ("openvino", "torch")
#: OpenVINO's names for :func:`gmcpt.device.generator_precision`'s
PRECISION_HINTS = {"float32": "f32", "bfloat16": "bf16"}
#: the code a converted network is made by: a change to either converts again
CONVERSION_CODE = ("model.py", "export.py")


def wanted_runtime() -> str:
    """``$GMCPT_GENERATOR_RUNTIME``: ``openvino`` (also :data:`~gmcpt.device.AUTO`, the default) or ``torch``."""
    wanted = os.environ.get(RUNTIME_ENV) or AUTO
    if wanted not in (AUTO, *RUNTIMES):
        raise BadValue(f"generator runtime {wanted!r}: use {AUTO}, {' or '.join(RUNTIMES)}")
    return "openvino" if wanted == AUTO else wanted


def cache_dir() -> Path:
    return cache_folder("generators")


def model_path(weights_file: Path, weights_sha256: str | None = None) -> Path:
    """Where the converted network of ``weights_file`` is kept: named by the weights' and the code's hashes."""
    import openvino

    here = Path(__file__).parent
    code = hashlib.sha256(b"".join((here / name).read_bytes() for name in CONVERSION_CODE)).hexdigest()
    weights = weights_sha256 or checked_weights(weights_file, check_hash=False)[2]
    return cache_dir() / f"{weights_file.stem}-{weights[:16]}-{code[:8]}-ov{openvino.get_version().split('-')[0]}.xml"


@dataclass(frozen=True)
class NetworkInputs:
    """What a converted network takes: the optional feature channels, and the multiple its sides must be."""

    use_variance: bool
    use_coverage: bool
    multiple: int


class CpuNetwork:
    """The compiled network: ``network(radiance, features, fill)`` -> the correction, all (1, H, W, C) float32."""

    def __init__(self, compiled, inputs: NetworkInputs):
        self.compiled = compiled
        self.inputs = inputs

    def __call__(self, radiance: np.ndarray, features: np.ndarray, fill: np.ndarray) -> np.ndarray:
        request = self.compiled.create_infer_request()  # one per call: callers may run frames on several threads
        return request.infer([radiance, features, fill], share_inputs=True)[0]


def compile_network(weights_file: Path, precision: str, threads: int | None = None,
                    weights_sha256: str | None = None) -> CpuNetwork:
    """The network of ``weights_file`` compiled for the CPU (on ``threads`` threads, else OpenVINO's choice),
    converted first where no usable copy is on disk."""
    import openvino

    core, path = openvino.Core(), model_path(weights_file, weights_sha256)
    config = {"INFERENCE_PRECISION_HINT": PRECISION_HINTS[precision], "PERFORMANCE_HINT": "LATENCY",
              **({"INFERENCE_NUM_THREADS": threads} if threads else {})}
    if path.is_file():
        try:
            return _compiled(core, path, config)
        except (RuntimeError, OSError, ValueError, TypeError):  # a truncated or foreign file: converted again
            pass
    from .export import export
    from .weights import load_generator

    export(load_generator(weights_file)[0], path)
    return _compiled(core, path, config)


def _compiled(core, path: Path, config: dict) -> CpuNetwork:
    inputs = NetworkInputs(**json.loads(path.with_suffix(".json").read_text()))
    return CpuNetwork(core.compile_model(core.read_model(path), "CPU", config), inputs)


@functools.cache
def warn_once(reason: str) -> None:
    print(f"warning: the generator runs in PyTorch: {reason}", file=sys.stderr)


@functools.lru_cache(maxsize=8)
def _cached_network(weights_file: Path, weights_sha256: str, precision: str, threads: int | None
                    ) -> CpuNetwork | None:
    try:
        return compile_network(weights_file, precision, threads, weights_sha256)
    except GmcptError:  # weights that do not load: the error, not PyTorch
        raise
    except ImportError:
        warn_once("OpenVINO is not installed (pip install openvino)")
    except Exception as error:  # refused the model or the settings: PyTorch runs it instead
        warn_once(f"OpenVINO failed ({type(error).__name__}: {' '.join(str(error).split())[:160]})")
    return None


def cpu_network(weights: str | Path | None, precision: str, threads: int | None = None) -> CpuNetwork | None:
    """The generator of ``weights`` (a shipped name or a path; checked against its record) compiled on OpenVINO for
    ``threads`` threads (None: OpenVINO's choice) in ``precision``, kept for the process; None where
    ``$GMCPT_GENERATOR_RUNTIME`` is ``torch`` or OpenVINO is unusable."""
    if wanted_runtime() == "torch":
        return None
    path, _, digest = checked_weights(weights)
    return _cached_network(path.resolve(), digest, precision, threads)


def precomplete_on_cpu(network: CpuNetwork, frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                       exposure: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """:func:`gmcpt.gan.infer.precomplete` on ``network``, in numpy and OpenVINO alone (no torch)."""
    if exposure != 1.0:
        frame = exposed(frame, exposure)
    inputs = network.inputs
    radiance, features, fill, factor = network_arrays(frame, domain, inputs.use_variance, inputs.use_coverage,
                                                      inputs.multiple)
    return working_image(fill + network(radiance, features, fill), frame.shape, factor, exposure)
