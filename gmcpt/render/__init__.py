"""The renderer: loading a scene with ``masked_path`` in charge (:mod:`~gmcpt.render.scene`), the kernels that
trace the feature buffers, a pixel list and Mitsuba's own full frame (:mod:`~gmcpt.render.kernels`), the path
integrator that returns OIDN's guides from its own first hits (:mod:`~gmcpt.render.guided_path`), and the state
kept per Mitsuba scene (:mod:`~gmcpt.render.held`).

Above :mod:`gmcpt.completion` (a scene's integrator names its completion method); below
:mod:`gmcpt.sampling`, which decides what the kernels trace (docs/design.md, "Layers").
"""
