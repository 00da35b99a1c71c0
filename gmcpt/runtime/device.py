"""Where completion's torch work runs: a CUDA GPU when torch sees one, else the CPU.

``$GMCPT_DEVICE`` chooses instead (``cpu``, ``cuda``, ``cuda:1``), for the generator and the
low-rank stage alike; a :class:`~gmcpt.lowrank.params.LowRankParams` with an explicit ``device``
keeps it. Rendering picks its Mitsuba variant on its own terms (:mod:`gmcpt.runtime.variant`). Asking
for CUDA where torch sees no GPU is a one-line error, not a silent fall back to the CPU.

The generator's arithmetic (:func:`generator_precision`): bfloat16 on a CPU that multiplies it
natively (AVX512-BF16 or AMX), float32 elsewhere; ``$GMCPT_GENERATOR_PRECISION`` chooses instead.
"""
from __future__ import annotations

import functools
import os

from ..errors import BadValue
from .workers import threads_setting

DEVICE_ENV = "GMCPT_DEVICE"
PRECISION_ENV = "GMCPT_GENERATOR_PRECISION"
PRECISIONS = ("float32", "bfloat16")
#: a device setting that means: CUDA where torch sees a GPU, else the CPU
AUTO = "auto"


#: files that exist where a GPU driver torch could use is loaded (NVIDIA's, AMD's ROCm, WSL's): without any of
#: them CUDA cannot be available, and the answer needs no torch (a 6-7 s import on 2 cores)
GPU_DRIVER_FILES = ("/proc/driver/nvidia/version", "/dev/nvidia0", "/dev/nvidiactl", "/dev/kfd", "/dev/dxg")


def completion_device(wanted: str | None = None) -> str:
    """The torch device (``"cpu"``, ``"cuda"``, ``"cuda:N"``) for ``wanted``: a device name, or
    :data:`AUTO` / None for ``$GMCPT_DEVICE``'s (when set, else automatic)."""
    if wanted in (None, AUTO):
        wanted = os.environ.get(DEVICE_ENV) or AUTO
    if wanted == "cpu" or (wanted == AUTO and not any(os.path.exists(path) for path in GPU_DRIVER_FILES)):
        return "cpu"
    import torch

    if wanted == AUTO:
        return "cuda" if torch.cuda.is_available() else "cpu"
    try:
        device = torch.device(wanted)
    except (RuntimeError, TypeError):
        raise BadValue(f"device {wanted!r} is not a torch device; use cpu, cuda or cuda:N") from None
    if device.type not in ("cpu", "cuda"):
        raise BadValue(f"device {wanted!r}: completion runs on cpu or cuda")
    if device.type == "cuda" and not torch.cuda.is_available():
        raise BadValue(f"device {wanted!r}: torch sees no CUDA device (unset {DEVICE_ENV} to use the CPU)")
    return str(device)


def generator_threads() -> int:
    """The CPU threads the generator runs on: ``$GMCPT_TORCH_THREADS`` (:func:`gmcpt.runtime.workers.threads_setting`),
    else as many as torch is set to use."""
    import torch

    setting = threads_setting()
    return torch.get_num_threads() if setting is None else setting


def generator_precision(device: str, wanted: str | None = None) -> str:
    """The generator's arithmetic on torch ``device``: ``"float32"`` or ``"bfloat16"`` (autocast).

    ``wanted`` (else ``$GMCPT_GENERATOR_PRECISION``, else :data:`AUTO`) names one; automatic is
    bfloat16 on a CPU with native bfloat16 products (AVX512-BF16 or AMX tiles), where the generator
    takes two thirds of its float32 time at the same quality (measured in docs/experiments.md), and
    float32 elsewhere: emulated bfloat16 is slower, and on CUDA it has not been measured.
    """
    wanted = wanted or os.environ.get(PRECISION_ENV) or AUTO
    if wanted not in (AUTO, *PRECISIONS):
        raise BadValue(f"generator precision {wanted!r}: use {AUTO}, {' or '.join(PRECISIONS)}")
    if wanted != AUTO:
        return wanted
    return "bfloat16" if device == "cpu" and native_bfloat16() else "float32"


@functools.cache
def native_bfloat16() -> bool:
    """Whether this CPU multiplies bfloat16 natively (the AVX512-BF16 or AMX-tile flags of ``/proc/cpuinfo``, what
    torch's own checks read; False where there is no such file)."""
    try:
        with open("/proc/cpuinfo") as cpuinfo:
            flags = next((line.split(":", 1)[1].split() for line in cpuinfo if line.startswith("flags")), [])
    except OSError:
        return False
    return "avx512_bf16" in flags or "amx_tile" in flags
