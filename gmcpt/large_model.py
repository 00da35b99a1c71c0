"""OIDN's large model for a dense frame below budget 16: its guides topped up to 16 rays, which OIDN takes as clean
(:data:`gmcpt.denoise.CLEAN_GUIDE_RAYS`), where the scene's reading of what that buys says it pays.

The reading (:func:`gmcpt.budget.denoiser_proxy`) comes from a frame traced as a quarter, a quarter and a half of
its samples (from 2 to 7 samples a pixel: one, one and the rest), each denoised: how far the large model moves the
half against how far doubling the quarter's samples does. At budgets 2-7 that is the reading at 1 and 2 spp,
which was calibrated against the large model's gain at 2 spp (docs/experiments.md). It serves the next frames of
its budget (:attr:`gmcpt.costs.FrameCosts.denoisers`). The functions take the frame's trace
(:class:`gmcpt.sampling._Trace`).
"""
from __future__ import annotations

import time

from .seeds import CLEAN_GUIDE_SEED_OFFSET
from .budget import BudgetPlan, adaptive_first_spp, adaptive_pays, denoiser_proxy, large_model_pays
from .costs import completion_seconds
from .denoise import CLEAN_GUIDE_RAYS, denoise_oidn



def extra_seconds(pixels: int, rays: int, ray_seconds: float) -> float:
    """What the large model adds to a dense frame of ``pixels`` pixels with guides of ``rays`` rays: its own time over
    OIDN's usual model's (each as this process has measured it, :func:`gmcpt.costs.completion_seconds`), and the guide
    rays up to 16 at ``ray_seconds`` a ray a pixel."""
    large = completion_seconds(pixels, large=True) - completion_seconds(pixels)
    return large + (CLEAN_GUIDE_RAYS - rays) * ray_seconds


def large_model_rays(trace, plan: BudgetPlan, costs, rays: int, ray_seconds: float | None,
                     frame_seconds: float | None) -> tuple[int, tuple | None]:
    """(the guide rays a dense frame expected to take ``frame_seconds`` (None: not known yet) takes, the price of a
    reading or None): 16 where the scene's reading at this budget says the large model pays
    (:func:`~gmcpt.budget.large_model_pays`), else its ``rays``. Without a reading, a frame that could pay and traces
    one even launch splits its launch and reads the scene (:func:`read_denoiser`, which takes the price: the large
    model's extra seconds and the frame's, priced before any guide ray is added)."""
    if not 0 < rays < CLEAN_GUIDE_RAYS or frame_seconds is None or ray_seconds is None:
        return rays, None
    price = (extra_seconds(trace.sums.size, rays, ray_seconds), frame_seconds)
    if not large_model_pays(float("inf"), *price):  # too dear here whatever the scene reads
        return rays, None
    reading = costs.denoiser(round(plan.budget))
    if reading.remembered() is not None:
        proxy = trace.info["denoiser_proxy"] = reading.remembered()
        reading.learn(None)
        return (CLEAN_GUIDE_RAYS if large_model_pays(proxy, *price) else rays), None
    first = adaptive_first_spp(plan.budget, costs.probe.value)
    concentration = costs.concentration(first).remembered() if first else None
    one_launch = not first or (concentration is not None and not adaptive_pays(concentration))
    if int(plan.budget) < 2 or not one_launch:  # a split launch needs a sample a pixel in each of its first two
        return rays, None
    return rays, price


def read_denoiser(trace, plan: BudgetPlan, costs, both: tuple, images: tuple, price: tuple):
    """Read what the large model buys the scene at this budget from a frame's first quarter and half (``images``,
    (H, W, 3)), denoised with its guides and with the clean ones (``both``), and return the guides the frame
    takes after it (``price`` as :func:`large_model_rays` gives it); ``info`` records the reading
    (``denoiser_proxy``)."""
    start = time.perf_counter()
    guides, clean = both
    mine, theirs = guides.buffers(), clean.buffers()
    quarter, half = images
    proxy = denoiser_proxy(denoise_oidn(quarter, mine["albedo"], mine["normal"], guides.spp),
                           denoise_oidn(half, mine["albedo"], mine["normal"], guides.spp),
                           denoise_oidn(half, theirs["albedo"], theirs["normal"], clean.spp))
    costs.denoiser(round(plan.budget)).learn(proxy)
    trace.info["denoiser_proxy"] = proxy
    trace.timed("mask_s", start)
    return clean if large_model_pays(proxy, *price) else guides
