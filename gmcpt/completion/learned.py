"""Learned completion: ``gan`` (GAN pre-completion alone) and ``gan_pawnnm`` (the paper's full method).

``gan`` runs the shipped generator (:mod:`gmcpt.gan`) on the sparse frame in
the working domain and returns its output for every pixel: the traced pixels
are replaced too, since the generator also denoises them (METHOD.md: putting
the 16-spp samples back costs 1-3 dB). ``gan_pawnnm`` hands that
pre-completion to the low-rank refinement
(:func:`gmcpt.completion.lowrank.refine_low_rank`).

Both take ``weights=`` (a shipped name such as ``gan-cpu`` or a ``.pt`` path;
default :data:`gmcpt.gan.weights.DEFAULT_WEIGHTS`). Torch uses
``$GMCPT_TORCH_THREADS`` threads when set.
"""
from __future__ import annotations

import os
import time

import numpy as np

from ..domain import WorkingDomain
from ..frame import SparseFrame
from . import Completion, register_method


def gan_precompletion(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                      weights: str | None = None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(working-domain image (H, W, 3), demodulation factor, timings) from the generator."""
    import torch

    from ..gan.infer import precomplete
    from ..gan.weights import load_generator

    threads = os.environ.get("GMCPT_TORCH_THREADS")
    if threads:
        torch.set_num_threads(int(threads))
    start = time.perf_counter()
    generator, _ = load_generator(weights)
    loaded = time.perf_counter()
    working, factor = precomplete(generator, frame, domain)
    timings = {"load_weights_s": loaded - start, "pre_completion_s": time.perf_counter() - loaded}
    return working, factor, timings


@register_method("gan", min_size=8, summary="GAN pre-completion alone (fills and denoises every pixel)")
def complete_gan(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(), weights: str | None = None) -> Completion:
    """GAN pre-completion alone."""
    working, factor, timings = gan_precompletion(frame, domain, weights)
    return Completion(domain.inverse(working, factor), timings)


def _low_rank_min_size() -> int:
    try:
        from ..lowrank import DEFAULT
        return max(8, DEFAULT.patch_size)
    except ImportError:  # low-rank stage not installed yet
        return 8


@register_method("gan_pawnnm", min_size=_low_rank_min_size(),
                 summary="GAN pre-completion + block matching + PAWNNM (the paper's full method)")
def complete_gan_pawnnm(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(), weights: str | None = None,
                        params=None) -> Completion:
    """GAN pre-completion, then PAWNNM low-rank refinement."""
    from .lowrank import refine_low_rank

    working, _, timings = gan_precompletion(frame, domain, weights)
    result = refine_low_rank(frame, working, domain, params)
    result.timings.update(timings)
    return result
