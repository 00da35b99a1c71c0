"""A sample budget instead of a rate: how many pixels to trace, chosen per frame from a small probe.

``budget`` is the mean number of path samples a pixel, ``round(budget * W * H)`` in all. The sparse way is
the default's at rate ``budget / SPARSE_SPP`` x :data:`SPARSE_SPP` spp. A probe's samples say which way pays:

- **sparse** (the paper's way, the default's at a fixed rate): the second pass of ``two_pass``; the
  completion fills the untraced pixels. It wins where the feature buffers predict the radiance, and a
  pixel's 16-spp mean is already close to converged: the synthetic scenes.
- **dense**: every pixel is traced, as evenly as integers allow: uniform path tracing at the budget; OIDN
  denoises the whole frame. From :data:`ADAPTIVE_FROM_BUDGET` samples a pixel, where a first pass of every
  pixel finds the error concentrated (:func:`adaptive_pays`), the rest of the budget goes where the
  displayed image is noisiest, as adaptive path tracing places it (:mod:`gmcpt.sampling.adaptive`); below that budget,
  and where the error is spread, adaptive placement lost to even samples (docs/experiments.md). Below
  :data:`RELIABILITY_BELOW_BUDGET` a scene the probe did not read quiet also needs two launches of its first pass to
  agree on where the error is (:func:`error_reliability`): a noisy interior's first pass of 2 spp finds its fireflies
  concentrated.
  It wins on real interiors, where indirect light leaves even the 16-spp means noisy and a filled pixel
  is worse than a few samples of its own.

Before the choice the frame traces only what both ways need: guides (albedo, normal, depth, at about the
budget's samples a pixel, :func:`guide_spp`, without shadow rays) and, where the choice waits for it
(:func:`needs_probe`), a probe, :data:`PROBE_SHARE` of the pixels at :data:`PROBE_SPP` spread as blue noise.
Every reading is this frame's own: none is carried to the next frames, so that the same arguments and cost model
give the same image whatever came before (:mod:`gmcpt.sampling.costs`). A dense frame then costs what Mitsuba's own
render at the same samples plus an albedo/normal pass plus OIDN costs: its bulk is ``mi.render`` itself (over the
pixels the probe's samples have not already brought to its level: they stay in the image), and the samples left over
go one each to blue-noise pixels. A sparse frame tops the guides up to the full feature
pass (shadow rays included) and the probe's pixels up to :data:`SPARSE_SPP`, as part of its first pass.
Two signals choose dense, and so does time (:func:`sparse_pays`): the sparse way's extra work (the rest of
the feature pass, the placement, the generator), priced by the machine's cost model
(:class:`gmcpt.sampling.costs.CostModel`, never by this process's timings), must cost less than the samples a dense
frame would buy with it are worth:

- :func:`relative_variance`: the median, over the probe's pixels, of the variance of a pixel's mean over
  its squared brightness, scaled to a 16-spp mean. The synthetic evaluation scenes read 0.007-0.057, the real
  interiors 0.23-0.26: noise the fill cannot average away.
- :func:`edge_share`: the share of the frame near an edge of the guide pass's buffers, read before any path
  is traced. Sponza's courtyard is lit directly, so it reads 0.03 on the first signal, but its columns,
  arches and textures leave a fill from 30% of the pixels too little to go on: it reads 0.32, the other
  real scenes 0.15-0.26 and the synthetic ones 0.08-0.17 (256x256, guides of 5 rays a pixel, budget 4.8;
  docs/experiments.md). The share falls as the resolution grows, faster than the fill's difficulty does, so
  its threshold falls with the frame's size (:func:`edges_above`); it rises with a noisier guide pass.

A budget of :data:`SPARSE_SPP` or more, or one that buys every pixel a sample but not a probe beside
that (1 to about 1.04), is dense without a probe (:attr:`BudgetPlan.dense_only`).

All functions here are pure numpy; :func:`gmcpt.sampling.strategies.render_sparse_frame` runs the passes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import GmcptError
from ..limits import check_positive
from .adaptive import FIRST_SHARE
from .masks import mask_rng, sample_by_density
from .placement import first_pass_count

#: Samples of each traced pixel on the sparse side; 0.3 x 16 is the evaluation's 4.8-spp default.
SPARSE_SPP = 16
#: Samples of each probe pixel before the choice.
PROBE_SPP = 4
#: Share of the pixels the probe traces: its median moves by about 0.01 between seeds on every evaluation scene,
#: far less than the gap between the scenes that go dense and the others (docs/experiments.md).
PROBE_SHARE = 0.01
#: Fewest and most primary rays a pixel of the guide pass: the edge signal was set on passes of 4 to 16.
GUIDE_SPP_RANGE = (4, 16)
#: Below budget 16 a dense frame takes 16-ray guides as clean, which runs OIDN's large model, where the scene's
#: :func:`denoiser_proxy` reads at least this: the scenes above it gained from it, the others not always
#: (``benchmarks/denoiser_gain.py``, docs/experiments.md).
LARGE_MODEL_PROXY_ABOVE = 1.15
#: ... and where its extra seconds are under this share of the dense frame's: then even its least gain buys more
#: than the time would in samples.
LARGE_MODEL_SHARE_BELOW = 0.5
#: Above this :func:`relative_variance` the frame is traced dense (set in docs/experiments.md).
DENSE_ABOVE = 0.15
#: Above this :func:`edge_share` too, at 256x256 (docs/experiments.md); at other sizes :func:`edges_above`.
EDGES_ABOVE = 0.25
#: The edge share of a scene falls as its frame grows, as (side / 256) ** -EDGE_FALLOFF with the side the square
#: root of the pixels (fitted on two scenes at three sizes: docs/experiments.md).
EDGE_FALLOFF = 0.38
#: dB a dense frame gains after OIDN when its samples double (measured on the Cornell box: docs/experiments.md).
DENSE_GAIN_PER_DOUBLING = 2.0
#: dB the sparse way is expected to gain over a dense frame at the same samples where the signals choose it: the
#: mean over the synthetic evaluation scenes (docs/experiments.md).
SPARSE_GAIN = 1.4
#: From this budget a dense frame may place part of its samples adaptively: first passes of 2 spp and more read
#: where the error is; below it (a first pass of 1 spp) the reading did not tell the scenes that gain from those that
#: lose (docs/experiments.md). 3.2: the least budget whose first pass is 2 spp.
ADAPTIVE_FROM_BUDGET = 3.2
#: Below this budget a frame whose probe did not read it quiet (:data:`DENSE_ABOVE`) also needs its first pass's
#: error map to be reliable (:func:`error_reliability`): there a noisy interior's first pass of 2 spp reads noise as
#: concentration (docs/experiments.md). 4.8: the least budget whose first pass is 3 spp.
RELIABILITY_BELOW_BUDGET = 4.8
#: The split-half agreement of the first pass's error maps (:func:`error_reliability`) from which that error is
#: where the frame's error is: the real interior that gains from adaptive placement at 3.2 reads 0.89-0.90 at
#: 128-512 pixels a side, the ones that lose 0.53-0.77 (docs/experiments.md).
RELIABLE_ABOVE = 0.85
#: The share of the first pass's display error held by its noisiest :data:`TOP_SHARE` of pixels above which
#: adaptive placement pays: it parts the evaluation scenes that gained from those that did not
#: (docs/experiments.md).
ADAPTIVE_ABOVE = 0.16
TOP_SHARE = 0.05
#: The largest budget, as the largest spp of a masked render.
MAX_BUDGET = 4096
#: The chooser's outcomes, as the sidecar records them.
SPARSE, DENSE = "sparse", "dense"


def check_budget(budget, name: str = "budget") -> float:
    """``budget`` as a float in (0, :data:`MAX_BUDGET`], else a one-line :class:`GmcptError`."""
    return check_positive(budget, name, MAX_BUDGET, "samples a pixel")


@dataclass(frozen=True)
class BudgetPlan:
    """How a budget maps onto a frame of ``pixels`` pixels.

    Attributes
    ----------
    samples : path samples in all, ``round(budget * pixels)``.
    sparse_pixels : pixels of the sparse frame, ``samples // SPARSE_SPP`` (at most all of them).
    """

    budget: float
    pixels: int
    samples: int
    sparse_pixels: int

    @property
    def sparse_rate(self) -> float:
        return self.sparse_pixels / self.pixels

    @property
    def first_pass_pixels(self) -> int:
        """Pixels of the first pass: ``two_pass``'s first share of the sparse frame's."""
        return first_pass_count(self.sparse_pixels)

    @property
    def probe_pixels(self) -> int:
        """Pixels of the probe: :data:`PROBE_SHARE` of the frame, at most the sparse frame's first pass."""
        return min(max(1, int(round(self.pixels * PROBE_SHARE))), self.first_pass_pixels)

    @property
    def dense_after_probe(self) -> bool:
        """True when what the probe leaves of the budget gives every pixel a sample at least."""
        return self.samples - self.probe_pixels * PROBE_SPP >= self.pixels

    @property
    def dense_only(self) -> bool:
        """True when the frame is traced dense without a probe: the budget traces every pixel at
        :data:`SPARSE_SPP` or more (nothing to choose), or it buys every pixel a sample but not a probe
        beside that (below about 1.04 samples a pixel; at 1, the dense frame beat the sparse one on 8
        of the 9 evaluation scenes, by 2.5 dB on the real mean: docs/experiments.md)."""
        return self.sparse_pixels >= self.pixels or (self.samples >= self.pixels and not self.dense_after_probe)


def plan_budget(budget: float, pixels: int) -> BudgetPlan:
    """The :class:`BudgetPlan` of ``budget`` samples a pixel on ``pixels`` pixels; one-line error when the budget
    does not buy a single pixel at :data:`SPARSE_SPP` spp."""
    budget = check_budget(budget)
    samples = int(round(budget * pixels))
    sparse_pixels = min(pixels, samples // SPARSE_SPP)
    if sparse_pixels < 1:
        raise GmcptError(f"budget {budget:g} buys {samples} path samples on {pixels} pixels, less than one pixel "
                         f"at {SPARSE_SPP} spp; raise the budget or the resolution")
    return BudgetPlan(budget, pixels, samples, sparse_pixels)


def relative_variance(mean: np.ndarray, variance_of_mean: np.ndarray, samples: int = SPARSE_SPP) -> float:
    """Median over traced pixels of ``variance_of_mean / brightness^2``, brightness the mean of RGB, for means of
    ``samples`` samples scaled to means of :data:`SPARSE_SPP` (the variance falls as 1 / samples).

    ``mean`` is (n, 3), ``variance_of_mean`` (n,); black pixels (no light reached) are left out, and a frame
    with none left reads 0.
    """
    brightness = np.asarray(mean, np.float64).mean(axis=-1)
    lit = brightness > 1e-6
    if not lit.any():
        return 0.0
    ratio = np.asarray(variance_of_mean, np.float64)[lit] / brightness[lit] ** 2
    return float(np.median(ratio)) * samples / SPARSE_SPP


def edge_share(features: dict) -> float:
    """Mean over the frame of :func:`gmcpt.sampling.placement.binned_edges` of the feature buffers (a dict with
    ``albedo``, ``normal``, ``depth``, ``visibility``): the share of the frame near a feature edge, in [0, 1]."""
    from .placement import binned_edges

    return float(binned_edges(features["albedo"], features["normal"], features["depth"], features["visibility"]).mean())


def sparse_pays(extra_seconds: float, seconds_per_spp: float, budget: float) -> bool:
    """True when the sparse way's expected gain at equal samples (:data:`SPARSE_GAIN`) beats what a dense frame
    of ``budget`` samples a pixel would gain from the ``extra_seconds`` the sparse way costs on top of it, spent
    on more samples at ``seconds_per_spp`` for one sample a pixel (:data:`DENSE_GAIN_PER_DOUBLING`); both from the
    cost model (:class:`gmcpt.sampling.costs.CostModel`), so the answer is the same wherever the frame runs. The seconds
    buy samples at the path tracer's pace, not the whole frame's: a frame's fixed costs (guides, OIDN) do not grow with
    its samples, and on a cheap scene the extra seconds buy many samples a pixel.

    What adaptive placement would gain the dense frame is not weighed: the error's concentration is read from a
    dense frame's first pass, after the choice, and a reading of earlier frames would make the choice depend on
    them (docs/experiments.md, 2026-12-01)."""
    more = max(extra_seconds, 0.0) / max(seconds_per_spp, 1e-12)
    return SPARSE_GAIN > DENSE_GAIN_PER_DOUBLING * math.log2(1 + more / budget)


def edges_above(pixels: int) -> float:
    """:data:`EDGES_ABOVE` for a frame of ``pixels`` pixels, scaled as the edge share falls with the size."""
    return EDGES_ABOVE * (math.sqrt(pixels) / 256) ** -EDGE_FALLOFF


def choose(plan: BudgetPlan, statistic: float, edges: float, pays: bool = True) -> str:
    """:data:`DENSE` when the probe reads above :data:`DENSE_ABOVE`, the feature edges above :func:`edges_above`
    or the sparse way would not pay for its time (``pays``: :func:`sparse_pays`), and what the probe leaves of
    the budget gives every pixel a sample (:attr:`BudgetPlan.dense_after_probe`); :data:`DENSE` too when the
    plan is :attr:`~BudgetPlan.dense_only`; else :data:`SPARSE`."""
    if plan.dense_only:
        return DENSE
    wanted = statistic > DENSE_ABOVE or edges > edges_above(plan.pixels) or not pays
    return DENSE if wanted and plan.dense_after_probe else SPARSE


def needs_probe(plan: BudgetPlan, edges: float, pays: bool) -> bool:
    """True when the choice waits for a probe: the plan has a choice, and neither the feature ``edges`` nor time
    (``pays``) choose dense on their own. A dense frame without a probe is Mitsuba's render at the whole budget,
    in one launch; a sparse frame always probes, as the probe's pixels are part of its first pass (the same seed
    gives the same sparse frame)."""
    return not plan.dense_only and choose(plan, 0.0, edges, pays) == SPARSE


def guide_spp(budget: float, feature_spp: int) -> int:
    """Primary rays a pixel of a budget's guide pass: about the budget, within :data:`GUIDE_SPP_RANGE` and at most
    ``feature_spp`` (what a baseline's renderer gathers over its own samples). From 16 OIDN takes them as clean
    (:data:`gmcpt.image.denoise.CLEAN_GUIDE_RAYS`), as it does a baseline's."""
    low, high = GUIDE_SPP_RANGE
    return max(1, min(feature_spp, high, max(low, int(round(budget)))))


def denoiser_proxy(quarter: np.ndarray, half: np.ndarray, clean_half: np.ndarray) -> float:
    """How far OIDN's large model moves a half frame's denoised image, over how far doubling the half's samples
    moves it: (RMS(clean_half - half) / RMS(quarter - half))^2 of the tonemapped images (``quarter``: a quarter of
    the frame's samples denoised as ``half`` is). No reference needed; it orders the scenes by what the large model
    gains them (docs/experiments.md)."""
    from ..image.metrics import tonemap

    half = tonemap(half)
    moved = lambda image: float(np.mean((tonemap(image) - half) ** 2))  # noqa: E731
    return moved(clean_half) / max(moved(quarter), 1e-12)


def large_model_pays(proxy: float, extra_seconds: float, frame_seconds: float) -> bool:
    """Whether a dense frame of ``frame_seconds`` takes OIDN's large model for ``extra_seconds`` more, after the
    scene's :func:`denoiser_proxy` (:data:`LARGE_MODEL_PROXY_ABOVE`, :data:`LARGE_MODEL_SHARE_BELOW`)."""
    return proxy >= LARGE_MODEL_PROXY_ABOVE and extra_seconds < LARGE_MODEL_SHARE_BELOW * frame_seconds


def even_fill(current: np.ndarray, samples: int, seed: int) -> np.ndarray:
    """More samples a pixel so that ``current`` (an (H, W) int count a pixel) plus them spends ``samples`` more
    and is as even as integers allow: every pixel up to a level L (none taken away), then one more each on
    ``samples`` left over pixels at L, spread as blue noise (:func:`gmcpt.sampling.masks.sample_by_density`, seeded).
    Returns an int64 (H, W) array."""
    current = np.asarray(current, np.int64)
    if samples < 0:
        raise GmcptError(f"cannot take {-samples} samples back")
    if current.min() == current.max():  # an even start (a dense frame without a probe): no search
        level, left = int(current.flat[0]) + samples // current.size, samples % current.size
        more = np.full(current.shape, level - int(current.flat[0]), np.int64)
        if left:
            more += sample_by_density(np.ones(current.shape, np.float32), left, mask_rng(seed))
        return more

    def need(level: int) -> int:
        return int(np.maximum(level - current, 0).sum())

    low, high = 0, int(current.max()) + samples // current.size + 1  # need(low) <= samples < need(high)
    while high - low > 1:
        middle = (low + high) // 2
        low, high = (middle, high) if need(middle) <= samples else (low, middle)
    more = np.maximum(low - current, 0)
    left = samples - int(more.sum())
    if left:
        at_level = (current + more) == low
        more += sample_by_density(np.ones(current.shape, np.float32), left, mask_rng(seed), exclude=~at_level)
    return more


def adaptive_first_spp(budget: float) -> int:
    """Samples of every pixel in a dense frame's first pass when the rest may be placed adaptively
    (:data:`~gmcpt.sampling.adaptive.FIRST_SHARE` of the budget), 0 below :data:`ADAPTIVE_FROM_BUDGET` (no first
    pass)."""
    return max(1, int(FIRST_SHARE * budget)) if budget >= ADAPTIVE_FROM_BUDGET else 0


def reads_reliability(budget: float, noise: float | None) -> bool:
    """True when a dense frame of ``budget`` traces its first pass as two launches and places adaptively only where
    their error maps agree (:func:`error_reliability`): below :data:`RELIABILITY_BELOW_BUDGET`, unless the frame's
    probe read its ``noise`` (:func:`relative_variance`; None: no probe) at most :data:`DENSE_ABOVE`."""
    quiet = noise is not None and noise <= DENSE_ABOVE
    return bool(adaptive_first_spp(budget)) and budget < RELIABILITY_BELOW_BUDGET and not quiet


def probes_for_placement(budget: float) -> bool:
    """True when a frame of ``budget`` probes for its placement alone, whatever its choice: the probe's reading
    would change how a dense frame reads its first pass (:func:`reads_reliability`). Every such frame probes, as a
    reading serves only its own frame."""
    return reads_reliability(budget, 0.0) != reads_reliability(budget, None)


def error_concentration(error: np.ndarray) -> float:
    """The share of ``error``'s sum (:func:`gmcpt.sampling.adaptive.display_error`) its largest :data:`TOP_SHARE` of
    pixels hold, in [0, 1]: :data:`TOP_SHARE` for an even error, 1 for one noisy spot."""
    error = np.asarray(error, np.float64).ravel()
    total = error.sum()
    if not total > 0:
        return 0.0
    top = max(1, int(round(TOP_SHARE * error.size)))
    return float(np.partition(error, error.size - top)[error.size - top:].sum() / total)


def error_reliability(first: np.ndarray, second: np.ndarray) -> float:
    """How far two independent error maps of one frame (:func:`gmcpt.sampling.adaptive.display_error` of two
    launches) agree: their correlation, in [-1, 1] (0 where either is flat). Where the error of a first pass of few
    samples is mostly where its fireflies fell, two launches put it in different places; where it is the scene's
    (bright edges, a sun patch), in the same."""
    first, second = (np.asarray(error, np.float64).ravel() for error in (first, second))
    first, second = first - first.mean(), second - second.mean()
    # products summed by numpy, not BLAS: where numpy was imported before gmcpt, a BLAS dot wakes OpenBLAS's threads,
    # whose spinning then slowed the frame's next launches and OIDN by about 10% (docs/experiments.md)
    scale = math.sqrt(float(np.sum(first * first)) * float(np.sum(second * second)))
    return float(np.sum(first * second) / scale) if scale > 0 else 0.0


def adaptive_pays(concentration: float, reliability: float | None = None) -> bool:
    """True when a dense frame's first pass reads its error as concentrated enough for adaptive placement, and, where
    it read it twice (``reliability``, :func:`error_reliability`), in the same places."""
    return concentration >= ADAPTIVE_ABOVE and (reliability is None or reliability >= RELIABLE_ABOVE)
