"""gmcpt: sparse path tracing in Mitsuba 3 with image completion.

Importing the package finds an LLVM for Dr.Jit (see :mod:`gmcpt.runtime.llvm`),
selects a Mitsuba variant when none is set (``$GMCPT_VARIANT``, else
``cuda_ad_rgb`` where CUDA works, else ``llvm_ad_rgb``) and registers the
``masked_path`` integrator with Mitsuba through its entry point
(:mod:`gmcpt.runtime.plugins`), so scene files that name it load with ``mi.load_file``.

The pipeline, one plain function per stage::

    render_sparse_frame(scene, ...)      -> SparseFrame   (gmcpt.sampling, over gmcpt.render's kernels)
    complete(frame, method)              -> Completion    (gmcpt.completion)
    write_outputs(path, frame, result)                     (gmcpt.io.outputs)

and the two first ones together, as the plugin, the CLI, regress and the evaluation run them:
``render_and_complete(scene, integrator, settings, method)`` (gmcpt.pipeline).
"""
from __future__ import annotations

__version__ = "0.1.0"

import os as _os

# OpenBLAS's threads busy-wait for a while after each call numpy makes (a reprojection's matrix product, an
# SVD): on 2 cores they took one from the path tracer that ran next, 35 ms of a 0.1 s render. Sleeping at once
# costs a call microseconds. Read when numpy loads OpenBLAS, so set before this package imports numpy.
_os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", "4")

from .errors import GmcptError  # noqa: E402
from .runtime.interrupts import startup as _startup

with _startup():  # the command line: a Ctrl-C during these imports is one line (see gmcpt.runtime.interrupts)
    from .runtime.llvm import configure_llvm as _configure_llvm

    _configure_llvm()

    from .runtime.variant import ensure_variant

    ensure_variant()

    from .frame import SparseFrame
    from .completion import Completion, complete, methods
    from .sampling.strategies import render_sparse_frame
    from .runtime.plugins import register_plugins

    register_plugins()  # masked_path (mitsuba_plugins, which imports this package; never the other way)

__all__ = ["GmcptError", "SparseFrame", "Completion", "complete", "methods",
           "render_sparse_frame", "ensure_variant", "__version__"]
