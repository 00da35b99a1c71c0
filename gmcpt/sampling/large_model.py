"""OIDN's large model for a dense frame below budget 16: its guides topped up to 16 rays, which OIDN takes as clean
(:data:`gmcpt.image.denoise.CLEAN_GUIDE_RAYS`), where the frame's reading of what that buys says it pays.

The reading (:func:`gmcpt.sampling.budget.denoiser_proxy`) comes from a frame traced as a quarter, a quarter and a half
of its samples (from 2 to 7 samples a pixel: one, one and the rest), each denoised: how far the large model moves the
half against how far doubling the quarter's samples does. At budgets 2-7 that is the reading at 1 and 2 spp,
which was calibrated against the large model's gain at 2 spp (docs/experiments.md). It serves its own frame alone,
so a frame reads only where the large model and the reading's three OIDN runs together would cost under
:data:`~gmcpt.sampling.budget.LARGE_MODEL_SHARE_BELOW` of it, by the frame's cost model
(:class:`gmcpt.sampling.costs.CostModel`). The functions take the frame's trace
(:class:`gmcpt.sampling.trace.FrameTrace`).
"""
from __future__ import annotations

import time

from ..image.denoise import CLEAN_GUIDE_RAYS, denoise_oidn
from ..seeds import CLEAN_GUIDE_SEED_OFFSET
from .budget import BudgetPlan, adaptive_first_spp, denoiser_proxy, large_model_pays, reads_reliability
from .trace import FrameTrace


def large_model_rays(trace: FrameTrace, plan: BudgetPlan, rays: int, noise: float | None) -> tuple[int, tuple | None]:
    """(the guide rays a dense frame of guides of ``rays`` rays takes, the price of a reading or None): ``rays``, and
    the price (the large model's extra seconds and the frame's, by ``trace.costs``) where the frame reads what the
    large model buys (:func:`read_denoiser`, which chooses the rays then). A frame reads where its one even launch
    can be split (2 samples a pixel or more, no first pass, or one read twice that leaves the rest even:
    :func:`~gmcpt.sampling.budget.reads_reliability`; ``noise`` is its probe's reading) and the large model with the
    reading's own OIDN runs could pay (:func:`~gmcpt.sampling.budget.large_model_pays`)."""
    if not 0 < rays < CLEAN_GUIDE_RAYS or int(plan.budget) < 2 or (adaptive_first_spp(plan.budget)
                                                                      and not reads_reliability(plan.budget, noise)):
        return rays, None
    model, pixels = trace.costs, plan.pixels
    price = (model.large_model_seconds(pixels, rays, CLEAN_GUIDE_RAYS), model.dense_seconds(pixels, plan.budget, rays))
    reading = 2 * model.completion_seconds(pixels) + model.completion_seconds(pixels, large=True)
    if not large_model_pays(float("inf"), price[0] + reading, price[1]):  # too dear here whatever the frame reads
        return rays, None
    return rays, price


def read_denoiser(trace: FrameTrace, both: tuple, images: tuple, price: tuple):
    """Read what the large model buys the frame from its first quarter and half (``images``, (H, W, 3)), denoised
    with its guides and with the clean ones (``both``), and return the guides the frame takes after it (``price``
    as :func:`large_model_rays` gives it); ``info`` records the reading (``denoiser_proxy``)."""
    start = time.perf_counter()
    guides, clean = both
    mine, theirs = guides.buffers(), clean.buffers()
    quarter, half = images
    proxy = denoiser_proxy(denoise_oidn(quarter, mine["albedo"], mine["normal"], guides.spp),
                           denoise_oidn(half, mine["albedo"], mine["normal"], guides.spp),
                           denoise_oidn(half, theirs["albedo"], theirs["normal"], clean.spp))
    trace.record(denoiser_proxy=proxy)
    trace.timed("mask_s", start)
    return clean if large_model_pays(proxy, *price) else guides
