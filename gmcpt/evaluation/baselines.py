"""The contenders that are not completion methods: full-frame path tracing (and, with
:func:`gmcpt.denoise.denoise_oidn` on it, path tracing + OIDN)."""
from __future__ import annotations

import numpy as np


def render_full(scene, integrator, spp: int, seed: int) -> np.ndarray:
    """Full-frame path tracing at ``spp`` samples per pixel, (H, W, 3) float32."""
    import drjit as dr
    import mitsuba as mi

    image = mi.render(scene, integrator=integrator, spp=spp, seed=seed)
    dr.eval(image)
    return np.asarray(image, dtype=np.float32)[..., :3]

