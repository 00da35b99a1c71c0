"""Choose the Mitsuba variant the pipeline runs in.

A variant this machine cannot run (``GMCPT_VARIANT=cuda_ad_rgb`` without a CUDA GPU, a misspelled
name) is a :class:`GmcptError` saying so in one line, never a fallback: timings and pixels then
always come from the variant asked for.
"""
from __future__ import annotations

import difflib
import os

from ..errors import GmcptError
from .llvm import require_llvm

SUPPORTED = ("llvm_ad_rgb", "cuda_ad_rgb")


def _cuda_available() -> bool:
    import drjit as dr
    try:
        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # pragma: no cover - depends on the driver
        return False


def check_wanted(wanted: str) -> None:
    """Refuse, in one line, a ``$GMCPT_VARIANT`` that gmcpt does not run in or this machine cannot."""
    if wanted not in SUPPORTED:
        close = difflib.get_close_matches(wanted, SUPPORTED, n=1, cutoff=0.8)
        hint = f"did you mean {close[0]}? " if close else ""
        raise GmcptError(f"GMCPT_VARIANT={wanted} is not a Mitsuba variant gmcpt runs in; {hint}"
                         f"use one of {', '.join(SUPPORTED)}, or unset it")
    if wanted.startswith("cuda") and not _cuda_available():
        raise GmcptError(f"GMCPT_VARIANT={wanted} needs a CUDA GPU, and Dr.Jit finds none on this machine; "
                         "set it to llvm_ad_rgb, or unset it")


def ensure_variant() -> str:
    """Select a vectorised RGB variant if none is active; return its name.

    A variant the user already chose is kept when it is supported; ``$GMCPT_VARIANT``
    picks one explicitly (:func:`check_wanted`).
    """
    import mitsuba as mi

    current = mi.variant()
    wanted = os.environ.get("GMCPT_VARIANT") or None  # set but empty: as if unset
    if current in SUPPORTED and not wanted:
        return current
    if wanted is None:
        wanted = "cuda_ad_rgb" if _cuda_available() else "llvm_ad_rgb"
    check_wanted(wanted)
    if wanted.startswith("llvm"):
        require_llvm()
    mi.set_variant(wanted)
    return wanted
