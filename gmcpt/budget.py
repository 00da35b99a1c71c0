"""A sample budget instead of a rate: how many pixels to trace, chosen per frame from its first pass.

``budget`` is the mean number of path samples a pixel, ``round(budget * W * H)`` in all. The frame starts
as the default does at rate ``budget / SPARSE_SPP`` x :data:`SPARSE_SPP` spp: the first pass of ``two_pass``
traces half of those pixels where the feature buffers have edges. Its samples then say which way pays:

- **sparse** (the paper's way, the default's at a fixed rate): the second pass of ``two_pass``; the
  completion fills the untraced pixels. It wins where the feature buffers predict the radiance, and a
  pixel's 16-spp mean is already close to converged: the synthetic scenes.
- **dense**: every untraced pixel is traced too, the rest of the budget spread evenly over them (the
  remainder one sample each where the displayed image looks noisiest); OIDN denoises the whole frame.
  Placing a share of it as adaptive path tracing does (:mod:`gmcpt.adaptive`) was 0.06 dB worse on the real
  scenes' mean (docs/experiments.md).
  It wins on real interiors, where indirect light leaves even the 16-spp means noisy and a filled pixel
  is worse than a few samples of its own.

The first pass traces its pixels at :data:`PROBE_SPP` only, so that choosing dense wastes little of the budget
on them; the sparse way then tops them up to :data:`SPARSE_SPP`. The signal is :func:`relative_variance`: the
median, over the first pass's pixels, of the variance of a pixel's mean over its squared brightness, scaled to
a 16-spp mean. The synthetic evaluation scenes read 0.01-0.07, the real interiors 0.06-0.63
(docs/experiments.md).

All functions here are pure numpy; :func:`gmcpt.render.render_sparse_frame` runs the passes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .adaptive import allocate, display_error
from .errors import GmcptError

#: Samples of each traced pixel on the sparse side; 0.3 x 16 is the evaluation's 4.8-spp default.
SPARSE_SPP = 16
#: Samples of each first-pass pixel before the choice.
PROBE_SPP = 4
#: Above this :func:`relative_variance` the frame is traced dense (set in docs/experiments.md).
DENSE_ABOVE = 0.15
#: The largest budget, as the largest spp of a masked render.
MAX_BUDGET = 4096
#: The chooser's outcomes, as the sidecar records them.
SPARSE, DENSE = "sparse", "dense"


def check_budget(budget, name: str = "budget") -> float:
    """``budget`` as a float in (0, :data:`MAX_BUDGET`], else a one-line :class:`GmcptError`."""
    try:
        value = float(budget)
    except (TypeError, ValueError):
        raise GmcptError(f"{name} must be a number of samples a pixel in (0, {MAX_BUDGET}], got {budget!r}") from None
    if not math.isfinite(value) or not 0 < value <= MAX_BUDGET:
        raise GmcptError(f"{name} must be in (0, {MAX_BUDGET}] samples a pixel, got {budget}")
    return value


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
    def dense_only(self) -> bool:
        """True when the budget traces every pixel at :data:`SPARSE_SPP` or more: nothing to choose."""
        return self.sparse_pixels >= self.pixels


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


def choose(plan: BudgetPlan, statistic: float, untraced: int, first_samples: int) -> str:
    """:data:`DENSE` when the first pass reads above :data:`DENSE_ABOVE` and what is left of the budget gives
    each of the ``untraced`` pixels a sample at least; else :data:`SPARSE`."""
    if plan.dense_only:
        return DENSE
    return DENSE if statistic > DENSE_ABOVE and plan.samples - first_samples >= untraced else SPARSE


def dense_spp(untraced: int, left: int) -> int:
    """Samples of each untraced pixel in the dense way's even pass: all that the ``left`` samples allow."""
    return max(1, left // max(untraced, 1))


def dense_extra(image: np.ndarray, extra: int) -> np.ndarray:
    """The dense way's last samples, fewer than its pixels: one each where the (H, W, 3) frame so far looks
    noisiest, as adaptive path tracing ranks them (:func:`gmcpt.adaptive.display_error`); an int64 count a flat
    pixel."""
    return allocate(display_error(image), extra, 1)
