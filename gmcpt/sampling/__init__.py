"""Where a frame's path samples go: the strategies (:mod:`~gmcpt.sampling.strategies`:
:func:`~gmcpt.sampling.strategies.render_sparse_frame`), a budget's sparse or dense choice
(:mod:`~gmcpt.sampling.budget`) and the cost model it weighs time with (:mod:`~gmcpt.sampling.costs`), the masks
(:mod:`~gmcpt.sampling.masks`) and the densities they follow (:mod:`~gmcpt.sampling.placement`), the dense way
(:mod:`~gmcpt.sampling.dense`, :mod:`~gmcpt.sampling.large_model`) and adaptive path tracing
(:mod:`~gmcpt.sampling.adaptive`).

Above :mod:`gmcpt.render` (its kernels) and :mod:`gmcpt.completion` (what a completion costs); below
:mod:`gmcpt.temporal` (docs/design.md, "Layers").
"""
