"""What a frame costs on this machine, learnt as a process renders: the budget chooser weighs time with it.

Per scene and frame size, :class:`FrameCosts` keeps the seconds one sample a pixel of path tracing takes,
the seconds the sparse way adds to a dense frame (the rest of the feature pass, the placement, the generator),
and what the last probe read of the scene's noise, the last dense frame of its error's concentration and the last
guide pass of its aliasing, so that the next frames can skip the probe, a dense frame's second launch where its
samples stay even, and guide rays that buy nothing.
Before a scene's first frame it knows no pace, and that frame goes dense (:mod:`gmcpt.sampling`); until a
sparse frame has run, the sparse way's extra work is a per-pixel guess (:data:`SPARSE_EXTRA_SECONDS_PER_PIXEL`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from .denoise import CLEAN_GUIDE_RAYS, denoise_oidn
from .held import scene_state

#: The sparse way's extra seconds a pixel before the process has seen a sparse frame: the rest of the feature
#: pass, the placement and the generator took 1.6 us a pixel on the bundled scenes at 256x256 (2 cores).
SPARSE_EXTRA_SECONDS_PER_PIXEL = 1.6e-6
#: Frames a reading of the scene serves before the frame reads again (a camera that moves may change it): the
#: probe's readings sit far from their threshold, 0.007-0.057 on the synthetic scenes and 0.23-0.26 on the real ones.
#: A frame that reads again costs up to 12% more (the probe or first pass adds launches); spread over 32 frames
#: that is under 0.5% a frame, where 8 cost 1.5% and put a reading frame among most settings' timed runs
#: (docs/experiments.md).
READ_AGAIN_AFTER = 32


@dataclass
class Reading:
    """The last reading of one of a scene's signals, which serves the next :data:`READ_AGAIN_AFTER` frames."""

    value: float | None = None
    frames: int = 0  # frames since it was read

    def remembered(self) -> float | None:
        """The reading while it serves, else None."""
        return self.value if self.frames < READ_AGAIN_AFTER else None

    def learn(self, value: float | None) -> None:
        """Count a frame, and keep ``value`` when the frame read the signal (not None)."""
        if value is not None:
            self.value, self.frames = value, 0
        self.frames += 1


@dataclass
class FrameCosts:
    """Seconds of one frame's parts on one scene at one size (the last measured, or None), and the readings of
    the scene's signals that let its next frames skip a pass."""

    pixels: int
    seconds_per_spp: float | None = None  # path tracing, one sample for every pixel
    sparse_extra_seconds: float | None = None  # what the sparse way adds to a dense frame's work
    guide_ray_seconds: float | None = None  # a guide pass (no shadow rays), per ray a pixel, its launch included
    probe: Reading = field(default_factory=Reading)  # relative variance (gmcpt.budget.relative_variance)
    concentrations: dict = field(default_factory=dict)  # first-pass spp -> Reading (budget.error_concentration)
    aliasing: Reading = field(default_factory=Reading)  # of the guides' albedo (budget.guide_aliasing)
    denoisers: dict = field(default_factory=dict)  # budget -> Reading (budget.denoiser_proxy)

    def concentration(self, first_spp: int) -> Reading:
        """The reading of a dense frame's error concentration after a first pass of ``first_spp`` samples a pixel:
        one a first pass, as the share grows with its samples (the still life 0.19 after 5, 0.21 after 10), so a
        budget-8 frame's reading chose even placement for budget-16 frames, which gain 0.4 dB from adaptive."""
        return self.concentrations.setdefault(first_spp, Reading())

    def denoiser(self, budget: int) -> Reading:
        """The reading of what OIDN's large model buys a dense frame of ``budget`` samples a pixel: one a budget, as
        it moves with the samples (the still life 1.20 at 4, 1.00 at 8)."""
        return self.denoisers.setdefault(budget, Reading())

    def extra_seconds(self) -> float:
        return (self.sparse_extra_seconds if self.sparse_extra_seconds is not None
                else SPARSE_EXTRA_SECONDS_PER_PIXEL * self.pixels)

    # the fewest seconds seen: a scene's first frame in a process compiles kernels and loads the generator
    def learn_path(self, seconds_per_spp: float) -> None:
        self.seconds_per_spp = min(seconds_per_spp, self.seconds_per_spp or np.inf)

    def learn_guide_ray(self, seconds_per_ray: float) -> None:
        self.guide_ray_seconds = min(seconds_per_ray, self.guide_ray_seconds or np.inf)

    def learn_extra(self, seconds: float) -> None:
        self.sparse_extra_seconds = min(seconds, self.sparse_extra_seconds or np.inf)


#: OIDN's seconds a pixel before the process has run it (2 cores: about 0.06 s at 256x256 and 1.9 s at 1920x1080 on
#: one machine, 0.11 s at 256x256 on a slower one), and its large model's over its usual model's before that has run
#: (2.3 there: 0.13 against 0.055 s at 256x256, 4.0 against 1.8 s at 1920x1080).
DENOISE_SECONDS_PER_PIXEL = 1.0e-6
LARGE_MODEL_TIME_RATIO = 2.3

#: The fewest seconds a pixel each of OIDN's models has taken in this process (None: not measured yet): what a
#: time budget keeps back for the completion, and what a budget's chooser counts in a dense frame. A model's first
#: run in a process loads it (2 s against 0.11 at 256x256) and is not counted.
_denoise_pace = {"usual": None, "large": None}
_denoise_runs = {"usual": 0, "large": 0}


def completion_seconds(pixels: int, large: bool = False) -> float:
    """Seconds the denoiser is expected to take on a frame of ``pixels`` pixels: its usual model, or with ``large``
    its large model (OIDN over clean guides, :func:`gmcpt.denoise.takes_clean_guides`)."""
    usual = _denoise_pace["usual"] or DENOISE_SECONDS_PER_PIXEL
    if large:
        return pixels * (_denoise_pace["large"] or LARGE_MODEL_TIME_RATIO * usual)
    return pixels * usual


def record_denoise(seconds: float, pixels: int, large: bool = False) -> None:
    """Learn from a denoiser run of ``seconds`` on ``pixels`` pixels (its large model's with ``large``), but its
    first in the process."""
    key = "large" if large else "usual"
    _denoise_runs[key] += 1
    if _denoise_runs[key] > 1:
        _denoise_pace[key] = min(seconds / max(pixels, 1), _denoise_pace[key] or np.inf)


def measure_denoiser(size: int = 64) -> None:
    """Time OIDN's two models on a ``size`` x ``size`` image where this process has not (each run twice: the first
    loads the model). A time budget's first frame in a process keeps the completion's seconds back from these, not
    from :data:`DENOISE_SECONDS_PER_PIXEL`, a guess that was a quarter of OIDN's pace on a slower machine (a 10-s
    budget spent 11 s); a small image's pace is the higher, so the estimate errs short."""
    image = np.full((size, size, 3), 0.5, np.float32)
    for large in (False, True):
        while _denoise_pace["large" if large else "usual"] is None:
            start = time.perf_counter()
            denoise_oidn(image, image, image, CLEAN_GUIDE_RAYS if large else 0)
            record_denoise(time.perf_counter() - start, size * size, large)


def frame_costs(scene, pixels: int) -> FrameCosts:
    """The costs of ``scene`` at ``pixels`` pixels learnt so far in this process (kept in its
    :func:`~gmcpt.held.scene_state`, let go with the scene)."""
    return scene_state(scene).setdefault("costs", {}).setdefault(pixels, FrameCosts(pixels))
