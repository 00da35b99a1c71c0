"""The dense way of a budget's frame (:mod:`gmcpt.sampling.budget`): every pixel traced, as evenly as integers allow,
and OIDN's guides for it.

The bulk is Mitsuba's own render (:func:`gmcpt.render.kernels.render_native`); the samples left over go one each to
blue-noise pixels; from :func:`~gmcpt.sampling.budget.adaptive_first_spp` the rest may be placed adaptively. Where the
choice did not wait for the guides (their edges choose nothing), the guides come from the render's own first hits
(:class:`gmcpt.render.guided_path.GuidedPath`, the same image) and a guide pass traces only the rays they lack: a
separate pass costs what Mitsuba's ``aov`` integrator costs a user, 4-10% of the render. OIDN gets a little less
from guides that share the radiance's sub-pixel positions (the Cornell box 0.02-0.18 dB at equal samples, the real
interiors nothing measurable; docs/experiments.md); the scenes where it shows read their edges below budget 16.

The functions take the frame's trace (:class:`gmcpt.sampling.trace.FrameTrace`) and change it through its methods.
"""
from __future__ import annotations

import functools
import time
from typing import Callable

import numpy as np

from ..image.denoise import CLEAN_GUIDE_RAYS
from ..limits import SEED_LIMIT
from ..render.guided_path import twin_of
from ..render.kernels import render_native, render_native_guided
from ..seeds import (EVEN_SEED_OFFSET, GUIDE_RAYS_SEED_OFFSET, RELIABILITY_SEED_OFFSET, SPLIT_SEED_OFFSETS,
                     TOP_UP_SEED_OFFSET, stream)
from .adaptive import EXPONENT, EXTRA_SEED_OFFSET, MAX_EXTRA, allocate, display_error
from .budget import (PROBE_SPP, BudgetPlan, adaptive_first_spp, adaptive_pays, error_concentration, error_reliability,
                     even_fill, reads_reliability)
from .large_model import CLEAN_GUIDE_SEED_OFFSET, large_model_rays, read_denoiser
from .trace import FrameTrace



def guides_from_render(trace: FrameTrace, wants_edges: bool) -> bool:
    """Whether a frame takes its guides from its render's first hits: no edges are read before the render, and a twin
    of its integrator exists (then set as the frame's, :func:`takes_twin`)."""
    return not wants_edges and takes_twin(trace)


def takes_twin(trace: FrameTrace) -> bool:
    """Set the frame's twin (:func:`~gmcpt.render.guided_path.twin_of`), through which its native passes bring their
    first hits as guides; whether its integrator has one."""
    return trace.use_twin(twin_of(trace.scene, trace.integrator))


def dense_frame(trace: FrameTrace, plan: BudgetPlan, probe: np.ndarray, guides, planned_rays: int, noise: float | None):
    """Trace the dense way (:func:`trace_dense`) and return its guides (:class:`~gmcpt.render.kernels.FeatureMeans`):
    ``guides`` from a guide pass, or None for the render's own first hits topped up to ``planned_rays``; up to 16
    rays where OIDN's large model pays (:func:`gmcpt.sampling.large_model.large_model_rays`). ``noise``: the frame's
    probe reading (None: no probe)."""
    rays, price = large_model_rays(trace, plan, planned_rays, noise)
    if guides is not None:
        guides = topped_up(trace, guides, rays, CLEAN_GUIDE_SEED_OFFSET)
    images = trace_dense(trace, plan, probe, noise, split=price is not None)
    trace.record(guides="pass" if guides is not None else "render")
    if guides is None:
        guides = topped_up(trace, trace.native_guides, rays, GUIDE_RAYS_SEED_OFFSET)
    if images is not None:
        clean = topped_up(trace, guides, CLEAN_GUIDE_RAYS, CLEAN_GUIDE_SEED_OFFSET)
        guides = read_denoiser(trace, (guides, clean), images, price)
    return guides


def topped_up(trace: FrameTrace, guides, rays: int, seed_offset: int):
    """``guides`` with a guide pass of the rays they lack up to ``rays`` (other seeds), or as they are."""
    if guides.spp >= rays:
        return guides
    return guides.merged(trace.features(rays - guides.spp, seed_offset, visibility=False))


def trace_dense(trace: FrameTrace, plan: BudgetPlan, probe: np.ndarray, noise: float | None = None,
                split: bool = False) -> tuple | None:
    """The dense way: what the probe left of the budget, as evenly as integers allow, the probe's samples kept in
    the image; the bulk Mitsuba's own render (over the pixels the probe did not already bring to its level), the
    rest one sample each on blue-noise pixels. Where :func:`~gmcpt.sampling.budget.adaptive_first_spp` allows it
    (from budget 3.2) the bulk is a first pass and the rest, and where the first finds the error concentrated
    (:func:`~gmcpt.sampling.budget.adaptive_pays`) the rest is adaptive path tracing's placement instead
    (:func:`_adaptive_rest`); below 4.8, unless its probe read the scene quiet (``noise``: the probe's reading, None:
    no probe), the first pass is two launches whose error maps must also agree
    (:func:`~gmcpt.sampling.budget.reads_reliability`). Every such frame reads its own concentration. With
    ``split``, an even launch of 2 samples a pixel or more is traced in three instead (:func:`_split_native`; a first
    pass read twice that leaves the rest even is those launches' first two); returns (the first quarter's image, the
    half's), else None."""
    seed = trace.settings.seed
    left = plan.samples - trace.sums.samples
    trace.count_first_pass(probe.sum())
    current = np.where(probe, PROBE_SPP, 0)  # the samples a pixel so far
    first, images = adaptive_first_spp(plan.budget), None
    if first:
        below = current < first  # a probe's pixels at the first pass's samples already are left out of it
        launch_images = _first_pass(trace, first, seed, reads_reliability(plan.budget, noise), below)
        current[below] += first
        left -= first * int(below.sum())
        if _adaptive_rest(trace, left, seed, launch_images):
            trace.mark_all_traced()
            return None
        if split and launch_images is not None:  # a quarter and a half of a frame of 3 or 4 spp, as _split_native's
            one, rest = launch_images()
            images = (one, (one + (first - 1) * rest) / first)
        # the second launch draws other samples than the first
        seed = (seed + EVEN_SEED_OFFSET) % SEED_LIMIT
    start = time.perf_counter()
    counts = even_fill(current.reshape(trace.shape), left, (seed + EVEN_SEED_OFFSET) % SEED_LIMIT).ravel()
    trace.timed("mask_s", start)
    # the frame's own seed: at an integral budget without a probe the frame is Mitsuba's render of that seed
    trace.mark_all_traced()
    level = int(counts[counts > 0].min()) if counts.any() else 0
    bulk = counts >= level
    if split and not first and level >= 2:
        images = _split_native(trace, level, seed, bulk)
    elif level:
        _launch(trace, bulk, level, seed)
    _top_up(trace, np.where(bulk, counts - level, counts), seed)
    return images


def _top_up(trace: FrameTrace, counts: np.ndarray, seed: int) -> None:
    """``counts`` more samples of each flat pixel, one launch for each count (one sample each on blue-noise pixels;
    a probe's pixels below the level, more), each count's own seed."""
    for count in np.unique(counts[counts > 0]):
        trace.trace(np.flatnonzero(counts == count), int(count), stream(seed, TOP_UP_SEED_OFFSET * int(count)))


def _launch(trace: FrameTrace, where: np.ndarray, spp: int, seed: int) -> np.ndarray | None:
    """``spp`` samples of the flat pixels ``where`` (bool): Mitsuba's render (:func:`native_pass`) where that is
    every pixel, else the pixel-list kernel. Returns the launch's own image, flat: (N, 3), or (n, 3) over ``where``
    (:func:`_launch_images` makes frames of them)."""
    if where.all():
        return native_pass(trace, spp, seed)
    return trace.trace(np.flatnonzero(where), spp, seed)


def _launch_images(trace: FrameTrace, where: np.ndarray, *launches: np.ndarray) -> list[np.ndarray]:
    """Launches' own images over ``where`` (:func:`_launch`) as (H, W, 3), non-finite pixels as 0 and the pixels they
    left out as the frame's estimate there (a probe's pixels, which the launches of a first pass or a split leave
    as they are)."""
    if where.all():
        return [_finite_image(trace, flat) for flat in launches]
    elsewhere = np.array(trace.sums.mean(), np.float32)
    images = []
    for own in launches:
        flat = elsewhere.copy()
        flat[where] = own
        images.append(_finite_image(trace, flat))
    return images


def native_pass(trace: FrameTrace, spp: int, seed: int, any_size: bool = False, note: str = "") -> np.ndarray | None:
    """Mitsuba's own render of every pixel at ``spp`` (none at 0) into the frame's sums, through the frame's twin
    where it has one (its first hits join ``trace.native_guides``). ``any_size``: through the
    frozen kernel at any spp (:func:`~gmcpt.render.kernels.render_native`); ``note`` ends the progress line. Returns the
    image, flat (N, 3)."""
    if not spp:
        return None
    start = time.perf_counter()
    trace.say(f"path tracing: {trace.sums.size} px x {spp} spp (Mitsuba's own render{note})")
    if trace.twin is not None:
        image, guides = render_native_guided(trace.scene, trace.sensor, trace.twin, spp, seed, any_size)
    else:
        image, guides = render_native(trace.scene, trace.sensor, trace.integrator, spp, seed, any_size), None
    trace.add_native(image, spp, guides)
    trace.timed("render_s", start)
    return image


def _split_native(trace: FrameTrace, spp: int, seed: int, where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``spp`` samples of the flat pixels ``where`` (:func:`_launch`) as a quarter, a quarter and a half (seeds of
    their own; below 4 samples, one, one and the rest): the first quarter's image and the half's, (H, W, 3) float32,
    non-finite pixels as 0."""
    quarter, launches = max(1, spp // 4), []
    for count, offset in ((quarter, 0), (quarter, SPLIT_SEED_OFFSETS[0]), (spp - 2 * quarter, SPLIT_SEED_OFFSETS[1])):
        launches.append(_launch(trace, where, count, (seed + offset) % SEED_LIMIT))
    first, second = _launch_images(trace, where, *launches[:2])
    return first, (first + second) / 2


def _finite_image(trace: FrameTrace, flat: np.ndarray) -> np.ndarray:
    """A launch's flat (N, 3) image as (H, W, 3), non-finite pixels as 0."""
    return np.nan_to_num(flat, posinf=0.0, neginf=0.0).reshape(*trace.shape, 3)


def _first_pass(trace: FrameTrace, spp: int, seed: int, twice: bool, where: np.ndarray) -> Callable | None:
    """A dense frame's first pass of ``spp`` samples of the flat pixels ``where`` (:func:`_launch`); ``twice``: as a
    launch of 1 and one of the rest (another seed), whose images (:func:`_launch_images`) the function it returns
    makes, once, where a reading asks for them (else None)."""
    if not twice:
        _launch(trace, where, spp, seed)
        return None
    one = _launch(trace, where, 1, seed)
    rest = _launch(trace, where, spp - 1, stream(seed, RELIABILITY_SEED_OFFSET))
    return functools.cache(lambda: _launch_images(trace, where, one, rest))


def _adaptive_rest(trace: FrameTrace, samples: int, seed: int, launch_images: Callable | None = None) -> bool:
    """After a dense frame's first pass, ``samples`` more where the displayed image is noisiest, as
    :func:`gmcpt.sampling.adaptive.render_adaptive` places them, if its error is concentrated enough to pay and,
    where the first pass was read twice (``launch_images``, which makes the images of its two launches), in the same
    places (:func:`~gmcpt.sampling.budget.adaptive_pays`; their images and agreement are made only where the
    concentration pays: two error maps cost 4% of a frame at budget 4). Returns whether it traced them; ``info``
    records the readings."""
    start = time.perf_counter()
    mean = trace.sums.mean()
    error = display_error(mean.reshape(*trace.shape, 3))
    concentration, reliability = error_concentration(error), None
    if launch_images is not None and adaptive_pays(concentration):
        reliability = error_reliability(*(display_error(image) for image in launch_images()))
    adaptive = adaptive_pays(concentration, reliability)
    trace.record(error_concentration=concentration, error_reliability=reliability,
                 dense_placement="adaptive" if adaptive else "even")
    if adaptive:
        cap = max(MAX_EXTRA, 2 * -(-samples // trace.sums.size))  # room for the rest at budgets above 64
        counts = allocate(error ** EXPONENT, samples, cap)
    trace.timed("mask_s", start)
    if adaptive:
        trace.say(f"path tracing: {samples} samples where the image is noisiest (adaptive placement)")
        trace.trace_counts(counts, (seed + EXTRA_SEED_OFFSET) % SEED_LIMIT)
    return adaptive
