"""Classical completion methods: ``none`` and ``interp``.

``interp`` is the strongest non-learned baseline we ship (docs/design.md section 5):
the feature-guided fill of :mod:`gmcpt.image.fills` on demodulated, log-compressed
radiance. Traced pixels keep their samples: this is a fill, not a denoiser.
"""
from __future__ import annotations

import numpy as np

from ..frame import SparseFrame
from ..image.domain import WorkingDomain
from ..image.fills import GuidedFillParams, interpolate
from . import Completion, register_method


@register_method("none", summary="the sparse image as rendered (0 where not traced)")
def complete_none(frame: SparseFrame) -> Completion:
    """The sparse image as rendered."""
    return Completion(np.where(frame.mask[..., None], frame.radiance, 0.0).astype(np.float32))


@register_method("interp", min_size=1,
                 summary="feature-guided interpolation on demodulated radiance (classical baseline)")
def complete_interp(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(),
                    params: GuidedFillParams = GuidedFillParams()) -> Completion:
    """Feature-guided interpolation on demodulated, log-compressed radiance."""
    return Completion(interpolate(frame, domain, params))
