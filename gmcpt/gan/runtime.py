"""The generator's network on OpenVINO, the CPU inference runtime it runs on by default.

The network proper (:meth:`~gmcpt.gan.model.Generator.correction`: the numpy fill stays outside the graph
and comes in as an input) is converted once per weights file (:mod:`gmcpt.gan.export`, in PyTorch) and kept on
disk as OpenVINO IR (``$GMCPT_CACHE`` or ``~/.cache/gmcpt``, folder ``generators``) under a name made of the
weights file's sha256, the model code's and OpenVINO's version. A process that finds it there runs the
generator without importing torch (:func:`precomplete_on_cpu`; the import alone is 6-7 s on 2 cores).
The compiled network is cached too (folder ``generators/compiled``, :func:`compiled_path`: named by the
converted network, the compile settings and the CPU), so a one-shot process imports it instead of compiling;
an entry is written under a temporary name and renamed, checked against its sha256 before OpenVINO reads it,
and one that is missing, damaged or unwritable is compiled again (a cache that cannot be written is no error).
Compiled networks live as long as the process. It runs in bfloat16 where
:func:`gmcpt.runtime.device.generator_precision` says so, as the PyTorch path does. Where OpenVINO is missing or fails,
:func:`cpu_network` says so in one line on stderr, once, and returns None: the caller runs the generator in PyTorch.
``$GMCPT_GENERATOR_RUNTIME`` ``torch`` keeps PyTorch (training and CUDA always use it).
"""
from __future__ import annotations

import functools
import glob
import hashlib
import io
import json
import os
import platform
import sys
import tempfile
import threading
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..errors import BadValue, GmcptError
from ..frame import SparseFrame
from ..image.domain import WorkingDomain
from ..io.files import atomic_output, cache_folder, check_writable
from ..runtime.device import AUTO
from .inputs import exposed, network_arrays, working_image
from .names import checked_weights

RUNTIME_ENV = "GMCPT_GENERATOR_RUNTIME"
RUNTIMES = ("openvino", "torch")
#: OpenVINO's names for :func:`gmcpt.runtime.device.generator_precision`'s
PRECISION_HINTS = {"float32": "f32", "bfloat16": "bf16"}
#: the code a converted network is made by: a change to either converts again
CONVERSION_CODE = ("model.py", "export.py")
#: the first line of a compiled-network file (:func:`store_compiled`): a file without it is not read
COMPILED_FORMAT = b"gmcpt compiled network 1\n"
#: OpenVINO's model-conversion tools, which ``import openvino`` loads unless told not to (:func:`openvino_module`)
CONVERTER_MODULE = "openvino.tools.ovc"

_IMPORTING = threading.Lock()


def wanted_runtime() -> str:
    """``$GMCPT_GENERATOR_RUNTIME``: ``openvino`` (also :data:`~gmcpt.runtime.device.AUTO`, the default) or
    ``torch``."""
    wanted = os.environ.get(RUNTIME_ENV) or AUTO
    if wanted not in (AUTO, *RUNTIMES):
        raise BadValue(f"generator runtime {wanted!r}: use {AUTO}, {' or '.join(RUNTIMES)}")
    return "openvino" if wanted == AUTO else wanted


def cache_dir() -> Path:
    return cache_folder("generators")


def openvino_module():
    """``openvino``, imported without its model-conversion tools where it is not loaded yet: the package's
    ``__init__`` imports them (with their telemetry, http and ssl) for ``openvino.convert_model``, a good part of
    the import's time in a process that only reads a converted network. ``openvino.convert_model`` then loads
    on first use (:func:`_converter`), so :mod:`gmcpt.gan.export` and other callers see no difference."""
    with _IMPORTING:
        hide = "openvino" not in sys.modules and CONVERTER_MODULE not in sys.modules
        if hide:
            sys.modules[CONVERTER_MODULE] = None  # the package's ``from openvino.tools.ovc import ...``: ImportError
        try:
            import openvino
        finally:
            if hide:
                del sys.modules[CONVERTER_MODULE]
        if hide and "convert_model" not in vars(openvino):
            openvino.__getattr__ = _converter
    return openvino


def _converter(name: str):
    """The module ``__getattr__`` (PEP 562) that :func:`openvino_module` gives ``openvino``: ``convert_model``,
    imported when first asked for."""
    if name != "convert_model":
        raise AttributeError(f"module 'openvino' has no attribute {name!r}")
    from openvino.tools.ovc import convert_model

    return convert_model


def model_path(weights_file: Path, weights_sha256: str | None = None) -> Path:
    """Where the converted network of ``weights_file`` is kept: named by the weights' and the code's hashes."""
    openvino = openvino_module()
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
    """The network of ``weights_file`` compiled for the CPU (on ``threads`` threads, else OpenVINO's choice): read
    back compiled where a usable copy is cached, else compiled from the converted network (converted first where
    no usable copy is on disk) and cached compiled for the next process."""
    core, path = openvino_module().Core(), model_path(weights_file, weights_sha256)
    config = {"INFERENCE_PRECISION_HINT": PRECISION_HINTS[precision], "PERFORMANCE_HINT": "LATENCY",
              **({"INFERENCE_NUM_THREADS": threads} if threads else {})}
    stored = compiled_path(path, config)
    network = read_compiled(core, stored, config)
    if network is None:
        network = _read_converted(core, path, config) or _convert(core, weights_file, path, config)
        store_compiled(stored, network)
    return network


def _read_converted(core, path: Path, config: dict) -> CpuNetwork | None:
    """The converted network at ``path`` compiled, or None where there is none or it does not read."""
    if path.is_file():
        try:
            return _compiled(core, path, config)
        except (RuntimeError, OSError, ValueError, TypeError):  # a truncated or foreign file: converted again
            pass
    return None


def _convert(core, weights_file: Path, path: Path, config: dict) -> CpuNetwork:
    """Convert the network of ``weights_file`` (PyTorch) and compile it. The conversion is kept at ``path``, or
    in a temporary folder for this call alone where the cache folder cannot be written (a read-only home)."""
    from .export import export
    from .weights import load_generator

    generator = load_generator(weights_file)[0]
    if _writable(path.parent):
        export(generator, path)
        return _compiled(core, path, config)
    with tempfile.TemporaryDirectory() as folder:
        export(generator, Path(folder) / path.name)
        return _compiled(core, Path(folder) / path.name, config)


def _writable(folder: Path) -> bool:
    """Whether files can be made in ``folder`` (made where missing)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        check_writable(folder / "probe")
    except (OSError, GmcptError):
        return False
    return True


def _compiled(core, path: Path, config: dict) -> CpuNetwork:
    inputs = NetworkInputs(**json.loads(path.with_suffix(".json").read_text()))
    return CpuNetwork(core.compile_model(core.read_model(path), "CPU", config), inputs)


@functools.cache
def cpu_identity() -> str:
    """The CPU's model name and feature flags (``/proc/cpuinfo``), else the machine's architecture: a compiled
    network is made for one kind of CPU, and one cache folder may serve several machines."""
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            lines = [line for line in cpuinfo if line.startswith(("model name", "flags"))]
    except OSError:
        lines = []
    return "".join(sorted(set(lines))) or platform.machine()


def compiled_path(model: Path, config: dict) -> Path:
    """Where the converted network ``model`` compiled with ``config`` is cached: its name (the weights, the code
    and OpenVINO's version) and a hash of ``config`` and :func:`cpu_identity`."""
    settings = json.dumps({"config": config, "cpu": cpu_identity()}, sort_keys=True).encode()
    return model.parent / "compiled" / f"{model.stem}-{hashlib.sha256(settings).hexdigest()[:12]}.blob"


def read_compiled(core, path: Path, config: dict) -> CpuNetwork | None:
    """The network :func:`store_compiled` wrote to ``path``, or None where there is none or it is damaged: the
    payload is checked against its recorded sha256 before OpenVINO reads it."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    if not data.startswith(COMPILED_FORMAT):
        return None
    header, _, payload = data[len(COMPILED_FORMAT):].partition(b"\n")
    try:
        record = json.loads(header)
        if record["sha256"] != hashlib.sha256(payload).hexdigest():
            return None
        return CpuNetwork(core.import_model(payload, "CPU", config), NetworkInputs(**record["inputs"]))
    except (ValueError, KeyError, TypeError, RuntimeError):  # a foreign header, or OpenVINO refused it
        return None


def store_compiled(path: Path, network: CpuNetwork) -> None:
    """Cache ``network`` compiled at ``path`` for the next process: written under a temporary name and renamed,
    so that a reader sees a whole entry or none; older entries of the same weights go. Where it cannot be
    written or exported nothing is cached, with no message: the network in hand is all this process needs."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as temporary:
            Path(temporary).write_bytes(_entry(network))
        _remove_older(path)
    except (OSError, RuntimeError, GmcptError):
        pass


def _entry(network: CpuNetwork) -> bytes:
    """A compiled-network file's bytes: :data:`COMPILED_FORMAT`, a line of JSON (the inputs the network takes and
    the sha256 of what follows), then OpenVINO's export of the compiled network."""
    stream = io.BytesIO()
    network.compiled.export_model(stream)
    payload = stream.getvalue()
    header = json.dumps({"inputs": asdict(network.inputs), "sha256": hashlib.sha256(payload).hexdigest()})
    return COMPILED_FORMAT + header.encode() + b"\n" + payload


def _remove_older(path: Path) -> None:
    """Remove the compiled networks of older conversions of ``path``'s weights (retrained, other code or
    OpenVINO); those of the same conversion with other settings stay."""
    converted = path.stem.rsplit("-", 1)[0]
    weights_name = converted.rsplit("-", 3)[0]
    for older in path.parent.glob(f"{glob.escape(weights_name)}-*.blob"):
        stem = older.stem
        if stem.count("-") == path.stem.count("-") and stem.rsplit("-", 1)[0] != converted:
            older.unlink(missing_ok=True)


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
