"""Choose the Mitsuba variant the pipeline runs in."""
from __future__ import annotations

import os

from ._llvm import require_llvm
from .errors import GmcptError

SUPPORTED = ("llvm_ad_rgb", "cuda_ad_rgb")


def _cuda_available() -> bool:
    import drjit as dr
    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # pragma: no cover - depends on the driver
        return False


def ensure_variant() -> str:
    """Select a vectorised RGB variant if none is active; return its name.

    A variant the user already chose is kept when it is supported; ``$GMCPT_VARIANT``
    picks one explicitly.
    """
    import mitsuba as mi

    current = mi.variant()
    wanted = os.environ.get("GMCPT_VARIANT")
    if current in SUPPORTED and not wanted:
        return current
    if wanted is None:
        wanted = "cuda_ad_rgb" if _cuda_available() else "llvm_ad_rgb"
    if wanted not in SUPPORTED:
        raise GmcptError(f"unsupported Mitsuba variant {wanted!r}; use one of {', '.join(SUPPORTED)}")
    if wanted.startswith("llvm"):
        require_llvm()
    mi.set_variant(wanted)
    return wanted
