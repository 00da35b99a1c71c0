"""Where a frame's path samples go: the strategies over the kernels of :mod:`gmcpt.render.kernels`.

- **a mask at a fixed rate** (:func:`_mask_passes`): the mask's pixels at the sampler's spp; ``two_pass``
  traces half of them by the feature edges, then the rest where those samples disagree
  (:mod:`gmcpt.sampling.placement`).
- **a budget** (:func:`_budget_passes`): guides and a probe, then the sparse way (``two_pass`` at rate
  ``budget / SPARSE_SPP``) or the dense one (Mitsuba's own render of every pixel), chosen per frame
  (:mod:`gmcpt.sampling.budget`) from the settings, what the frame reads and a cost model (:mod:`gmcpt.sampling.costs`):
  the same settings and model give the same frame, whatever ran before it.
- **a time budget** (:func:`_time_passes`): Mitsuba's own render of every pixel in passes sized by the time the
  passes before took, until the seconds left would not pay for another sample a pixel and the completion after
  them (in the spirit of Cycles' time limit); the guides from the passes' first hits. It spends wall time, so
  its samples follow the machine's pace: the one strategy whose frame is not the same on every run.

Every strategy traces into one :class:`~gmcpt.render.kernels.SampleSums`; :func:`render_sparse_frame` turns it and the
feature buffers into a :class:`~gmcpt.frame.SparseFrame`.
"""
from __future__ import annotations

import time
from dataclasses import replace

import mitsuba as mi
import numpy as np

from ..frame import SparseFrame
from ..image.denoise import takes_clean_guides
from ..limits import SEED_LIMIT, check_resolution, check_spp
from ..render.kernels import MAX_LANES, pass_seed, sensor_film_size, warm_native
from ..render.scene import scene_sensor
from ..seeds import FIRST_PASS_SEED_OFFSET, GUIDE_TOP_UP_SEED_OFFSET, PROBE_SEED_OFFSET, SECOND_PASS_SEED_OFFSET
from .budget import (DENSE, PROBE_SPP, SPARSE, SPARSE_SPP, BudgetPlan, choose, edge_share, guide_spp, needs_probe,
                     plan_budget, probes_for_placement, relative_variance, sparse_pays)
from .costs import machine_costs
from .dense import (GUIDE_RAYS_SEED_OFFSET, TOP_UP_SEED_OFFSET, dense_frame, guides_from_render, native_pass,
                    takes_twin, topped_up)
from .masks import FEATURE_PATTERNS, make_mask, mask_rng, sample_by_density, sample_count, second_pass_mask
from .placement import error_density, feature_density, first_pass_count
from .settings import RenderSettings, Say, check_one_sample_count
from .trace import FrameTrace

__all__ = ["RenderSettings", "Say", "check_one_sample_count", "render_sparse_frame"]


def _first_mask(settings: RenderSettings, features: dict, height: int, width: int,
                count: int | None = None, taken: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The mask of the (first) radiance pass, and the feature density (None for the patterns without one, and at
    rate 1). ``count`` (``two_pass``): pixels of the first pass instead of its share of the rate's, beside
    the ``taken`` (H, W) pixels, which it leaves out."""
    total = sample_count(settings.rate, height * width)
    if total == height * width:  # at rate 1 there is nothing to place (and no density to compute)
        return np.ones((height, width), bool), None
    if settings.pattern not in FEATURE_PATTERNS:
        return make_mask(height, width, settings.rate, settings.pattern, settings.seed), None
    density = feature_density(features["albedo"], features["normal"], features["depth"], features["visibility"],
                              features["coverage"])
    if settings.pattern == "adaptive":
        return make_mask(height, width, settings.rate, "adaptive", settings.seed, density), density
    first = first_pass_count(total) if count is None else count
    return sample_by_density(density, first, mask_rng(settings.seed), exclude=taken), density


def _second_pass(trace: FrameTrace, settings: RenderSettings, features: dict, density: np.ndarray, rest: int,
                 spp: int) -> None:
    """The second pass of ``two_pass``: ``rest`` more pixels where the first pass's samples disagree."""
    height, width = trace.shape
    start = time.perf_counter()
    first = trace.traced.reshape(height, width)
    radiance, variance, _ = trace.buffers()
    errors = error_density(radiance.reshape(height, width, 3), variance.reshape(height, width), first, features["albedo"], features["coverage"], density)
    second = np.flatnonzero(second_pass_mask(errors, rest, first, settings.seed))
    trace.timed("mask_s", start)
    trace.trace(second, spp, (settings.seed + SECOND_PASS_SEED_OFFSET) % SEED_LIMIT)


def _mask_passes(trace: FrameTrace, mask: np.ndarray | None, spp: int) -> dict:
    """The passes at a fixed rate: the mask's pixels at ``spp``, and for ``two_pass`` a second pass. Returns the
    feature buffers."""
    settings = trace.settings
    height, width = trace.shape
    features = trace.features(settings.feature_spp).buffers()
    start = time.perf_counter()
    density = None
    if mask is None:
        mask, density = _first_mask(settings, features, height, width)
    trace.timed("mask_s", start)
    pixels = np.flatnonzero(mask)
    trace.trace(pixels, spp, settings.seed)
    trace.count_first_pass(pixels.size)
    rest = sample_count(settings.rate, height * width) - pixels.size
    if settings.pattern == "two_pass" and density is not None and rest > 0:
        _second_pass(trace, settings, features, density, rest, spp)
    return features


def _budget_passes(trace: FrameTrace, plan: BudgetPlan) -> dict:
    """The passes of a budget (:mod:`gmcpt.sampling.budget`): guides, a probe where the choice waits for one
    (:func:`~gmcpt.sampling.budget.needs_probe`) or a dense frame's placement would
    (:func:`~gmcpt.sampling.budget.probes_for_placement`), then the sparse way or the dense one
    (:mod:`gmcpt.sampling.dense`; its guides come from its render where the choice did not read them,
    :func:`~gmcpt.sampling.dense.guides_from_render`). The choice weighs the plan, the frame's cost model
    (``trace.costs``) and this frame's readings alone. Returns the feature buffers."""
    model, feature_spp = trace.costs, trace.settings.feature_spp
    probe = np.zeros(plan.pixels, bool)
    reading, edges, extra_share, pays, for_placement = None, None, None, True, False
    if not plan.dense_only:
        extra_share = model.sparse_extra / model.dense_seconds(1, plan.budget, guide_spp(plan.budget, feature_spp))
        pays = sparse_pays(model.sparse_extra, model.path, plan.budget)
        for_placement = probes_for_placement(plan.budget)
    wants_edges = for_placement or needs_probe(plan, 0.0, pays)  # the edges could choose (0.06 s at 1920x1080)
    guides = features = None
    if not guides_from_render(trace, wants_edges):
        guides = trace.features(guide_spp(plan.budget, feature_spp), visibility=False)
        features = guides.buffers()
    if wants_edges:
        edges = edge_share(features)
        if for_placement or needs_probe(plan, edges, pays):
            probe = _probe(trace, plan)
            reading = relative_variance(*trace.sums.estimate(probe), PROBE_SPP)
    choice = choose(plan, reading or 0.0, edges or 0.0, pays)
    trace.record(budget=plan.budget, budget_choice=choice, relative_variance=reading,
                 probe="none" if reading is None else "traced", edge_share=edges, sparse_time_share=extra_share)
    signals = [f"relative variance {reading:.3f}" if reading is not None else "",
               f"edge share {edges:.2f}" if edges is not None else "",
               f"sparse time +{extra_share:.0%}" if extra_share is not None else ""]
    trace.say(f"budget {plan.budget:g} spp: {choice}" + (f" ({', '.join(filter(None, signals))})"
                                                         if any(signals) else ""))
    if choice == SPARSE:  # only after the edges were read: with guides from their pass
        trace.record(guide_spp=guides.spp)
        return _sparse_after_probe(trace, plan, guides, probe)
    rays = guides.spp if guides is not None else guide_spp(plan.budget, feature_spp)
    frame_guides = dense_frame(trace, plan, probe, guides, rays, reading)
    trace.record(guide_spp=frame_guides.spp)
    return features if frame_guides is guides else frame_guides.buffers()


def _probe(trace: FrameTrace, plan: BudgetPlan) -> np.ndarray:
    """Trace the probe: :attr:`~gmcpt.sampling.budget.BudgetPlan.probe_pixels` blue-noise pixels at ``PROBE_SPP``.
    Returns its flat bool mask."""
    seed = trace.settings.seed
    start = time.perf_counter()
    probe = sample_by_density(np.ones(trace.shape, np.float32), plan.probe_pixels,
                              mask_rng((seed + PROBE_SEED_OFFSET) % SEED_LIMIT)).ravel()
    trace.timed("mask_s", start)
    trace.say(f"path tracing: {int(probe.sum())} px x {PROBE_SPP} spp (probe)")
    trace.trace(np.flatnonzero(probe), PROBE_SPP, seed)
    return probe


def _sparse_after_probe(trace: FrameTrace, plan: BudgetPlan, guides, probe: np.ndarray) -> dict:
    """The sparse way: the feature pass completed (shadow rays), the probe's pixels topped up to ``SPARSE_SPP``
    beside the rest of the first pass (placed by the feature edges), then ``two_pass``'s second pass."""
    settings, seed = trace.settings, trace.settings.seed
    height, width = trace.shape
    more_rays = max(settings.feature_spp - guides.spp, PROBE_SPP)
    features = guides.merged(trace.features(more_rays, GUIDE_TOP_UP_SEED_OFFSET)).buffers()
    sparse = replace(settings, rate=plan.sparse_rate, budget=0.0)
    start = time.perf_counter()
    first, density = _first_mask(sparse, features, height, width, plan.first_pass_pixels - int(probe.sum()),
                                 probe.reshape(height, width))
    trace.timed("mask_s", start)
    # two pixel lists of even counts, not one of uneven counts: a pixel's samples stay consecutive lanes,
    # summed within their SIMD packet, and no per-sample index list is built in numpy
    trace.trace(np.flatnonzero(probe), SPARSE_SPP - PROBE_SPP, (seed + TOP_UP_SEED_OFFSET) % SEED_LIMIT)
    trace.trace(np.flatnonzero(first), SPARSE_SPP, (seed + FIRST_PASS_SEED_OFFSET) % SEED_LIMIT)
    trace.count_first_pass(trace.traced.sum())
    _second_pass(trace, sparse, features, density, plan.sparse_pixels - trace.first_pass_pixels, SPARSE_SPP)
    return features


def _time_passes(trace: FrameTrace) -> dict:
    """A time budget: every pixel at one sample, then passes of as many samples as the seconds left (less what the
    completion is expected to take) pay for at the pace of the passes so far, in powers of two
    (:func:`_next_pass`). All through the frozen kernel, one compiled kernel for every pass size: the first pass's
    pace is its own, its compilation done before it on a few pixels (``mi.render`` compiles a kernel for each spp,
    inside the frame); OIDN's seconds are the cost model's (``trace.costs``), measured on this machine beforehand.
    The guides come from the passes' own first hits where the integrator has a twin
    (:func:`~gmcpt.sampling.dense.takes_twin`): as many rays as samples, where a guide pass first would have given a
    frame of hundreds of samples four. Returns the feature buffers; ``info`` records the samples a pixel spent
    (``budget``)."""
    settings, seconds = trace.settings, trace.settings.time
    guides = None if takes_twin(trace) else trace.features(guide_spp(1, settings.feature_spp), visibility=False)
    warm_native(trace.scene, trace.sensor, trace.twin or trace.integrator, guided=trace.twin is not None)
    spp, index = 1, 0
    while True:
        start = time.perf_counter()
        native_pass(trace, spp, pass_seed(settings.seed, index, 2), any_size=True, note=f", {seconds:g} s in all")
        pace = (time.perf_counter() - start) / spp  # seconds per sample a pixel, the launch's own cost included
        spp, left = _next_pass(trace, seconds, pace)
        index += 1
        if spp < 1:
            break
    spent = int(trace.sums.samples // trace.sums.size)
    if guides is None:  # a frame of fewer samples than guide rays adds the rays it lacks
        guides = topped_up(trace, trace.native_guides, guide_spp(spent, settings.feature_spp), GUIDE_RAYS_SEED_OFFSET)
    trace.mark_all_traced()
    trace.record(time_budget=seconds, budget=float(spent), budget_choice=DENSE, guide_spp=guides.spp,
                 guides="pass" if trace.twin is None else "render", time_short=index == 1 and left < 0)
    return guides.buffers()


def _next_pass(trace: FrameTrace, seconds: float, pace: float) -> tuple[int, float]:
    """(the samples a pixel of a time budget's next pass, 0 for none; the seconds left before it): the whole
    samples nearest to what the seconds left pay for at ``pace``, less the completion's time, OIDN's large model's
    where the frame's guides would then have :data:`~gmcpt.image.denoise.CLEAN_GUIDE_RAYS` rays (its own samples' first
    hits), at most :data:`~gmcpt.render.kernels.MAX_LANES` lanes."""
    pixels = trace.sums.size
    samples, most = trace.sums.samples // pixels, max(1, MAX_LANES // pixels)
    for large in (False, True):
        left = seconds - (time.perf_counter() - trace.started) - trace.costs.completion_seconds(pixels, large)
        # the nearest whole sample, not the last one that fits: a short budget then ends within half a sample
        # of its seconds, where it fell up to one sample short (5 samples in 0.5 s: 11% under)
        spp = _pass_size(min(int(left / pace + 0.5), most))
        if large or trace.twin is None or not takes_clean_guides(samples + spp):
            return spp, left


def _pass_size(affordable: int) -> int:
    """The samples a pixel of a time budget's next pass: the largest power of two within ``affordable`` (0 for
    none). Each pass size is a recording of the frozen kernel of its own (a trace of the integrator in Python,
    0.03 s on the Cornell box): powers of two keep a scene to a few; the next passes take the rest."""
    return 1 << (affordable.bit_length() - 1) if affordable >= 1 else 0


def render_sparse_frame(scene: mi.Scene, integrator: mi.SamplingIntegrator, sensor: mi.Sensor | None = None,
                        settings: RenderSettings = RenderSettings(), mask: np.ndarray | None = None,
                        progress: Say | None = None) -> tuple[SparseFrame, dict]:
    """Render features for all pixels and radiance for the masked ones.

    Parameters
    ----------
    scene : a loaded Mitsuba scene.
    integrator : the integrator that computes radiance per ray (e.g. ``path``).
    sensor : defaults to the scene's first sensor.
    settings : rate, mask pattern, seed, spp, feature spp, budget.
    mask : an explicit (H, W) bool mask; overrides ``settings.rate/pattern/budget``.
    progress : called with a one-line status message before each pass.

    Returns
    -------
    (frame, timings) with timings ``features_s``, ``mask_s`` (placing the samples) and ``render_s``
    (path tracing, every pass) in seconds.

    With the ``two_pass`` pattern, a first radiance pass traces :func:`~gmcpt.sampling.placement.first_pass_count`
    pixels (``adaptive``), :func:`gmcpt.sampling.placement.error_density` reads its samples, and a second pass traces
    the rest of the budget on other pixels, with other sampler seeds. With a ``budget``, a probe's samples
    choose (:mod:`gmcpt.sampling.budget`) between that and a dense frame; ``info`` records the choice
    (``budget_choice``) and its signals (``relative_variance``, ``edge_share``).
    """
    say = progress or (lambda message: None)
    sensor = sensor if sensor is not None else scene_sensor(scene)
    height, width = sensor_film_size(sensor)
    check_resolution(width, height, settings.feature_spp)
    plan = plan_budget(settings.budget, height * width) if settings.budget and mask is None else None
    spp = SPARSE_SPP if plan is not None else check_spp(settings.spp or sensor.sampler().sample_count())
    started, costs = time.perf_counter(), None
    if (settings.time or plan is not None) and mask is None:  # the strategies that weigh time
        costs = settings.costs if settings.costs is not None else machine_costs(say)
    trace = FrameTrace(scene, sensor, integrator, settings, say, {"features_s": 0.0, "mask_s": 0.0, "render_s": 0.0},
                       (height, width), started=started, costs=costs)
    if costs is not None:
        trace.record(costs=costs.record())
    if settings.time and mask is None:
        features = _time_passes(trace)
    elif plan is not None:
        features = _budget_passes(trace, plan)
    else:
        features = _mask_passes(trace, mask, spp)

    sums = trace.sums
    radiance, variance, traced = trace.buffers()
    dense_guides = trace.info.budget_choice == DENSE and trace.info.guide_spp is not None
    info = trace.info.with_values(pattern=settings.pattern, seed=settings.seed,
                                  feature_spp=trace.info.guide_spp if dense_guides else settings.feature_spp,
                                  traced_pixels=int(traced.sum()), path_samples=int(sums.samples),
                                  nonfinite_samples=int(sums.samples - sums.finite.sum()),
                                  first_pass_pixels=int(trace.first_pass_pixels))
    frame = SparseFrame(radiance=radiance.reshape(height, width, 3), mask=traced.reshape(height, width),
                        variance=variance.reshape(height, width), spp=spp, info=info, **features)
    return frame, trace.timings

