"""The contenders that are not completion methods: full-frame path tracing (and, with
:func:`gmcpt.image.denoise.denoise_oidn` on it, path tracing + OIDN)."""
from __future__ import annotations

import numpy as np


def render_full(scene, integrator, spp: int, seed: int) -> np.ndarray:
    """Full-frame path tracing at ``spp`` samples per pixel, (H, W, 3) float32: the render a dense frame's bulk is
    (:func:`gmcpt.render.kernels.render_native`, ``mi.render`` or the same samples through the frozen kernel, whichever
    is faster at the size), so that the baselines' path tracer is as fast as the product's."""
    from ..render.kernels import render_native, sensor_film_size

    sensor = scene.sensors()[0]
    height, width = sensor_film_size(sensor)
    return render_native(scene, sensor, integrator, spp, seed).reshape(height, width, 3)

