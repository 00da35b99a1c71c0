"""Matrix-completion methods: ``pawnnm``, its ``nnm`` ablation and the image-only ``liu`` baseline.

Both pre-complete with the classical feature-guided fill (``interp``'s
:func:`~gmcpt.image.fills.guided_fill`), then refine the whole frame
with weighted block matching + low-rank group recovery
(:func:`gmcpt.lowrank.complete_low_rank`) in the working domain of
:mod:`gmcpt.image.domain`. :func:`refine_low_rank` is the shared second stage, which
the GAN methods reuse with their own pre-completion.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..frame import SparseFrame
from ..image.domain import WorkingDomain
from ..image.fills import guided_fill, push_pull
from ..lowrank.noise import working_variance
from ..lowrank.params import DEFAULT, NNM_PRESET, LowRankParams
from . import Completion, register_method

#: Working domain of the low-rank stage. A larger albedo regulariser than the
#: classical and GAN stages use (0.2 against 0.02): the 1-spp albedo buffer is
#: aliased at texture edges and noisy radiance over a dark albedo blows up when
#: divided by it, and both hurt the patch groups more than they hurt a local
#: fill. Measured with benchmarks/sweep_rendered.py (worst frame's gain over
#: interp, dB): 0.02 +2.8, 0.05 +3.2, 0.1 +3.6, 0.2 +3.6 (mean +4.4), 0.4 +3.6.
LOW_RANK_DOMAIN = WorkingDomain(albedo_eps=0.2)

#: Scale of the guide features in the matching distance, to match the 0..255-like
#: working domain: albedo and depth in [0, 1], normals in [-1, 1].
GUIDE_SCALE = np.array([255, 255, 255, 128, 128, 128, 255], np.float32)


def matching_guide(frame: SparseFrame) -> np.ndarray:
    """(H, W, 7) albedo, normal and depth on the working domain's scale."""
    return np.concatenate([frame.albedo, frame.normal, frame.depth[..., None]], axis=-1) * GUIDE_SCALE


def refine_low_rank(frame: SparseFrame, pre_completed_working: np.ndarray,
                    domain: WorkingDomain = LOW_RANK_DOMAIN, params: LowRankParams | None = None) -> Completion:
    """Low-rank refinement of a pre-completed frame given in the working domain.

    Returns the HDR image and the sub-stage timings (``block_matching_s``,
    ``svd_s``, ``aggregation_s``).
    """
    from ..lowrank.pawnnm import complete_low_rank  # torch: imported by the first completion that needs it

    params = params or DEFAULT
    observed, factor = domain.encode(frame)
    variance = working_variance(frame, domain, observed, factor)
    try:
        refined, timings = complete_low_rank(pre_completed_working, observed, frame.mask, variance=variance,
                                             guide=matching_guide(frame), params=params)
    except ValueError as error:
        from ..errors import GmcptError
        raise GmcptError(str(error)) from None
    return Completion(domain.inverse(refined, factor), dict(timings))


def _classical_then_low_rank(frame: SparseFrame, params: LowRankParams, domain: WorkingDomain) -> Completion:
    import time

    start = time.perf_counter()
    observed, _ = domain.encode(frame)
    pre_completed = guided_fill(observed, frame.mask, frame.features())
    pre_completion_s = time.perf_counter() - start
    result = refine_low_rank(frame, pre_completed, domain, params)
    result.timings["pre_completion_s"] = pre_completion_s
    return result


@register_method("pawnnm", min_size=DEFAULT.patch_size,
                 summary="classical pre-completion + block matching + PAWNNM (weighted thresholds)")
def complete_pawnnm(frame: SparseFrame, *, params: LowRankParams = DEFAULT,
                    domain: WorkingDomain = LOW_RANK_DOMAIN) -> Completion:
    """Classical pre-completion, then PAWNNM low-rank refinement."""
    return _classical_then_low_rank(frame, params, domain)


@register_method("nnm", min_size=NNM_PRESET.patch_size,
                 summary="classical pre-completion + block matching + NNM (constant threshold, ablation)")
def complete_nnm(frame: SparseFrame, *, params: LowRankParams = NNM_PRESET,
                 domain: WorkingDomain = LOW_RANK_DOMAIN) -> Completion:
    """Classical pre-completion, then constant-threshold NNM (paper Table 2 ablation)."""
    return _classical_then_low_rank(frame, params, domain)


#: The image-only baseline's low-rank settings: NNM with no guide features in the matching.
LIU_PRESET = replace(NNM_PRESET, feature_weight=0.0)


@register_method("liu", min_size=LIU_PRESET.patch_size,
                 summary="image-only baseline (Liu et al. 2018 style): push-pull fill + NNM, no feature buffers")
def complete_liu(frame: SparseFrame, *, params: LowRankParams = LIU_PRESET,
                 domain: WorkingDomain = LOW_RANK_DOMAIN) -> Completion:
    """Image-only baseline: push-pull pre-completion, then NNM, using no feature buffer.

    The paper's Table 1 baseline (docs/design.md section 5): the frame is treated as
    an image alone, so radiance is not divided by albedo (the working domain
    sees an albedo of 0, i.e. a factor of 1), the pre-completion is the
    feature-free push-pull fill, and block matching compares colours only.
    """
    import time

    image_only = replace(frame, albedo=np.zeros_like(frame.albedo))
    start = time.perf_counter()
    observed, _ = domain.encode(image_only)
    pre_completed = push_pull(observed, frame.mask.astype(np.float32))
    pre_completion_s = time.perf_counter() - start
    result = refine_low_rank(image_only, pre_completed, domain, params)
    result.timings["pre_completion_s"] = pre_completion_s
    return result
