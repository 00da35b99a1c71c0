"""Find an LLVM >= 16 shared library for Dr.Jit's ``llvm`` backend.

Dr.Jit 1.5 crashes on LLVM 14/15 ("Cannot select ... fminimum"), which is what
Debian 12 ships by default. We look for a newer ``libLLVM`` and point
``DRJIT_LIBLLVM_PATH`` at it before Mitsuba is imported, so users never set it
by hand. A value the user already set is respected.
"""
from __future__ import annotations

import glob
import os
import re

from ..errors import GmcptError

MIN_LLVM = 16
_SEARCH_GLOBS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM-*.so*",
    "/usr/lib/aarch64-linux-gnu/libLLVM-*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*",
    "/usr/lib64/libLLVM-*.so*",
    "/usr/local/lib/libLLVM*.so*",
    "/opt/homebrew/opt/llvm/lib/libLLVM.dylib",
    "/usr/local/opt/llvm/lib/libLLVM.dylib",
)
INSTALL_HINT = ("no LLVM >= 16 found for Mitsuba's llvm variants; install one "
                "(Debian/Ubuntu: `sudo apt-get install libllvm19`) or set "
                "DRJIT_LIBLLVM_PATH to a libLLVM shared library")


def _major_version(path: str) -> int:
    """Best-effort LLVM major version from a library path (0 if unknown)."""
    match = re.search(r"(?:LLVM-|llvm-|\.so\.)(\d+)", path)
    return int(match.group(1)) if match else 0


def find_libllvm() -> str | None:
    """Return the path of the newest usable libLLVM (major >= 16), or None."""
    candidates = []
    for pattern in _SEARCH_GLOBS:
        for path in glob.glob(pattern):
            version = _major_version(path)
            if version >= MIN_LLVM or path.endswith(".dylib"):
                candidates.append((version, path))
    if not candidates:
        return None
    return max(candidates)[1]


def configure_llvm() -> str | None:
    """Set ``DRJIT_LIBLLVM_PATH`` if the user has not; return the path in use.

    Returns None when no suitable library exists; :func:`require_llvm` turns
    that into a :class:`GmcptError` with installation advice.
    """
    current = os.environ.get("DRJIT_LIBLLVM_PATH")
    if current:
        return current
    found = find_libllvm()
    if found:
        os.environ["DRJIT_LIBLLVM_PATH"] = found
    return found


def require_llvm() -> str:
    path = configure_llvm()
    if not path or not os.path.exists(path):
        raise GmcptError(INSTALL_HINT if not path else
                         f"DRJIT_LIBLLVM_PATH={path} does not exist; " + INSTALL_HINT)
    return path
