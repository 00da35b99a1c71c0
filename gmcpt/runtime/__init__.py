"""The process around the work: Dr.Jit's LLVM (:mod:`~gmcpt.runtime.llvm`), the Mitsuba variant
(:mod:`~gmcpt.runtime.variant`) and plugins (:mod:`~gmcpt.runtime.plugins`), signals
(:mod:`~gmcpt.runtime.interrupts`), CPU threads and the torch device (:mod:`~gmcpt.runtime.workers`,
:mod:`~gmcpt.runtime.device`), progress lines (:mod:`~gmcpt.runtime.progress`) and Ray
(:mod:`~gmcpt.runtime.cluster`).

The lowest layer but the top-level modules (errors, limits, seeds, frame): it imports no other folder of
gmcpt (``tests/test_layers.py``; docs/design.md, "Layers").
"""
