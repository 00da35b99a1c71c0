"""The frame's trace (:class:`FrameTrace`): what one frame's strategy has in hand while it traces, shared by the
strategies (:mod:`gmcpt.sampling.strategies`), the dense way (:mod:`gmcpt.sampling.dense`) and OIDN's large model's
reading (:mod:`gmcpt.sampling.large_model`), which change it through its methods.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import mitsuba as mi
import numpy as np

from ..frame import FrameInfo
from ..limits import SEED_LIMIT
from ..render.kernels import FeatureMeans, SampleSums, feature_means
from .costs import CostModel
from .settings import RenderSettings, Say


@dataclass
class FrameTrace:
    """What one frame's strategy has in hand while it traces: the scene, the sums of its samples, the pixels it
    traced, its timings, and what it records of its choices (``info``, :class:`~gmcpt.frame.FrameInfo`). The
    strategies (:mod:`gmcpt.sampling.strategies`), the dense way (:mod:`gmcpt.sampling.dense`) and OIDN's large
    model's reading (:mod:`gmcpt.sampling.large_model`) change it through its methods alone."""

    scene: mi.Scene
    sensor: mi.Sensor
    integrator: mi.SamplingIntegrator
    settings: RenderSettings
    say: Say
    timings: dict
    shape: tuple[int, int]
    sums: SampleSums = None
    traced: np.ndarray = None  # flat bool
    started: float = field(default_factory=time.perf_counter)
    costs: CostModel | None = None  # what a budget or a time budget weighs time with (None: a rate weighs none)
    first_pass_pixels: int = 0
    info: FrameInfo = field(default_factory=FrameInfo)  # what it recorded of its choices so far
    twin: mi.SamplingIntegrator | None = None  # the integrator's guided twin, where the render brings the guides
    native_guides: FeatureMeans | None = None  # the guides of the twin's first hits so far

    def __post_init__(self):
        pixels = self.shape[0] * self.shape[1]
        self.sums, self.traced = SampleSums(pixels), np.zeros(pixels, bool)

    def buffers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The estimates so far as flat float32 radiance (N, 3) and variance (N,), 0 where untraced, and the traced
        pixels (N,) bool: a pixel whose every sample was NaN/Inf counts as untraced."""
        mean, variance = self.sums.estimate()
        traced = self.traced & (self.sums.finite > 0)
        if traced.all():  # a dense frame: nothing to blank (0.1 s at 1920x1080)
            return mean.astype(np.float32, copy=False), variance.astype(np.float32), traced
        return (np.where(traced[:, None], mean, 0.0).astype(np.float32),
                np.where(traced, variance, 0.0).astype(np.float32), traced)

    def use_twin(self, twin: mi.SamplingIntegrator | None) -> bool:
        """Set the integrator's guided twin (None: it has none); whether it has one."""
        self.twin = twin
        return twin is not None

    def count_first_pass(self, pixels: int) -> None:
        """Record the pixels of the first pass (a dense frame: its probe's)."""
        self.first_pass_pixels = int(pixels)

    def mark_all_traced(self) -> None:
        """Every pixel counts as traced (a dense frame)."""
        self.traced[:] = True

    def record(self, **values) -> None:
        """Record ``values`` of the frame's choices (:class:`~gmcpt.frame.FrameInfo`'s fields)."""
        self.info = self.info.with_values(**values)

    def add_native(self, image: np.ndarray, spp: int, guides: FeatureMeans | None = None) -> None:
        """Add Mitsuba's own render of every pixel at ``spp`` (flat (N, 3)) to the sums, and ``guides`` (its first
        hits, where it came through the twin) to the native guides."""
        if guides is not None:
            self.native_guides = guides if self.native_guides is None else self.native_guides.merged(guides)
        self.sums.add_native(image, spp)

    def timed(self, key: str, start: float) -> None:
        self.timings[key] = self.timings.get(key, 0.0) + time.perf_counter() - start

    def trace(self, pixels: np.ndarray, spp: int, seed: int) -> np.ndarray | None:
        """``spp`` samples of each flat pixel in ``pixels``; their own mean, (n, 3), NaN where none was finite."""
        start = time.perf_counter()
        mean = self.sums.trace(self.scene, self.sensor, self.integrator, pixels, spp, seed, self.say)
        self.traced[pixels] = True
        self.timed("render_s", start)
        return mean

    def trace_counts(self, counts: np.ndarray, seed: int) -> None:
        """``counts`` samples of each pixel (:meth:`~gmcpt.render.kernels.SampleSums.trace_counts`)."""
        start = time.perf_counter()
        self.sums.trace_counts(self.scene, self.sensor, self.integrator, counts, seed)
        self.timed("render_s", start)

    def features(self, spp: int, seed_offset: int = 0, visibility: bool = True):
        start = time.perf_counter()
        self.say(f"features: {self.shape[1]}x{self.shape[0]} px x {spp} spp"
                 + ("" if visibility else " (guides: albedo, normal, depth)"))
        means = feature_means(self.scene, self.sensor, spp, (self.settings.seed + seed_offset) % SEED_LIMIT,
                              visibility)
        self.timed("features_s", start)
        return means
