"""Sequences: frames that reuse the samples of the frames before them (:mod:`~gmcpt.temporal.sequence`), the
history's projection and weights in numpy (:mod:`~gmcpt.temporal.history`) and the same reprojection fused in
Dr.Jit (:mod:`~gmcpt.temporal.reprojection`).

Above :mod:`gmcpt.sampling`; the ``batch`` command writes a sequence's files (:mod:`gmcpt.cli.sequence_batch`)
(docs/design.md, "Layers").
"""
