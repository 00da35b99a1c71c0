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

from .budget import BudgetPlan, adaptive_first_spp, adaptive_pays, denoiser_proxy, large_model_pays
from .costs import completion_seconds
from .denoise import CLEAN_GUIDE_RAYS, denoise_oidn

CLEAN_GUIDE_SEED_OFFSET = 0xC1EA  # the guide rays a dense frame adds up to 16


def extra_seconds(trace, guides) -> float:
    """What the large model adds to a dense frame with ``guides``: its own time over OIDN's usual model's (each as
    this process has measured it, :func:`gmcpt.costs.completion_seconds`), and the guide rays up to 16 at the pace
    of the frame's guide pass."""
    ray_seconds = trace.timings.get("features_s", 0.0) / guides.spp
    large = completion_seconds(trace.sums.size, large=True) - completion_seconds(trace.sums.size)
    return large + (CLEAN_GUIDE_RAYS - guides.spp) * ray_seconds


def large_model_guides(trace, plan: BudgetPlan, costs, guides, frame_seconds: float | None):
    """(guides, clean, price) of a dense frame expected to take ``frame_seconds`` (None: not known yet): ``guides``
    topped up to 16 rays where the scene's reading at this budget says the large model pays
    (:func:`~gmcpt.budget.large_model_pays`), else ``guides``. Without a reading, a frame that could pay and traces
    one even launch gets the topped-up guides as ``clean`` too: it splits its launch and reads the scene
    (:func:`read_denoiser`, which takes ``price``: the large model's extra seconds and the frame's, priced
    before any guide ray is added)."""
    if not 0 < guides.spp < CLEAN_GUIDE_RAYS or frame_seconds is None:
        return guides, None, None
    price = (extra_seconds(trace, guides), frame_seconds)
    if not large_model_pays(float("inf"), *price):  # too dear here whatever the scene reads
        return guides, None, None
    reading = costs.denoiser(round(plan.budget))
    if reading.remembered() is not None:
        proxy = trace.info["denoiser_proxy"] = reading.remembered()
        reading.learn(None)
        return (clean_guides(trace, guides) if large_model_pays(proxy, *price) else guides), None, None
    first = adaptive_first_spp(plan.budget, costs.probe.value)
    concentration = costs.concentration(first).remembered() if first else None
    one_launch = not first or (concentration is not None and not adaptive_pays(concentration))
    if int(plan.budget) < 2 or not one_launch:  # a split launch needs a sample a pixel in each of its first two
        return guides, None, None
    return guides, clean_guides(trace, guides), price


def clean_guides(trace, guides):
    """``guides`` topped up to :data:`~gmcpt.denoise.CLEAN_GUIDE_RAYS` rays (other seeds)."""
    return guides.merged(trace.features(CLEAN_GUIDE_RAYS - guides.spp, CLEAN_GUIDE_SEED_OFFSET, visibility=False))


def read_denoiser(trace, plan: BudgetPlan, costs, both: tuple, images: tuple, price: tuple):
    """Read what the large model buys the scene at this budget from a frame's first quarter and half (``images``,
    (H, W, 3)), denoised with its guides and with the clean ones (``both``), and return the guides the frame
    takes after it (``price`` as :func:`large_model_guides` gives it); ``info`` records the reading
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
