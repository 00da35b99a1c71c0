"""Where completion's torch work runs: a CUDA GPU when torch sees one, else the CPU.

``$GMCPT_DEVICE`` chooses instead (``cpu``, ``cuda``, ``cuda:1``), for the generator and the
low-rank stage alike; a :class:`~gmcpt.lowrank.params.LowRankParams` with an explicit ``device``
keeps it. Rendering picks its Mitsuba variant on its own terms (:mod:`gmcpt.variant`). Asking
for CUDA where torch sees no GPU is a one-line error, not a silent fall back to the CPU.
"""
from __future__ import annotations

import os

from .errors import BadValue

DEVICE_ENV = "GMCPT_DEVICE"
#: a device setting that means: CUDA where torch sees a GPU, else the CPU
AUTO = "auto"


def completion_device(wanted: str | None = None) -> str:
    """The torch device (``"cpu"``, ``"cuda"``, ``"cuda:N"``) for ``wanted``: a device name, or
    :data:`AUTO` / None for ``$GMCPT_DEVICE``'s (when set, else automatic)."""
    if wanted in (None, AUTO):
        wanted = os.environ.get(DEVICE_ENV) or AUTO
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
