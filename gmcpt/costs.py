"""What a frame costs on this machine, learnt as a process renders: the budget chooser weighs time with it.

Per scene and frame size, :class:`FrameCosts` keeps the seconds one sample a pixel of path tracing takes,
the seconds the sparse way adds to a dense frame (the rest of the feature pass, the placement, the generator),
and what the last probe read of the scene's noise, so that the next frames can skip the probe.
Before a scene's first frame it knows only the probe's pace (an upper bound: a small launch pays its set-up)
and a per-pixel guess of the sparse way's extra work (:data:`SPARSE_EXTRA_SECONDS_PER_PIXEL`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .held import scene_state

#: The sparse way's extra seconds a pixel before the process has seen a sparse frame: the rest of the feature
#: pass, the placement and the generator took 1.6 us a pixel on the bundled scenes at 256x256 (2 cores).
SPARSE_EXTRA_SECONDS_PER_PIXEL = 1.6e-6
#: Frames a probe's reading serves before the chooser probes again (a camera that moves may change it): the
#: readings sit far from the threshold, 0.007-0.057 on the synthetic scenes and 0.23-0.26 on the real ones.
PROBE_AGAIN_AFTER = 8


@dataclass
class FrameCosts:
    """Seconds of one frame's parts on one scene at one size (the last measured, or None)."""

    pixels: int
    seconds_per_spp: float | None = None  # path tracing, one sample for every pixel
    sparse_extra_seconds: float | None = None  # what the sparse way adds to a dense frame's work
    probe_reading: float | None = None  # the last probe's relative variance (gmcpt.budget.relative_variance)
    frames_since_probe: int = 0

    def path_seconds(self, probe_seconds_per_sample: float) -> float:
        """Seconds of one sample a pixel: measured, else the probe's pace times the pixels."""
        return self.seconds_per_spp if self.seconds_per_spp is not None else probe_seconds_per_sample * self.pixels

    def extra_seconds(self) -> float:
        return (self.sparse_extra_seconds if self.sparse_extra_seconds is not None
                else SPARSE_EXTRA_SECONDS_PER_PIXEL * self.pixels)

    def remembered_reading(self) -> float | None:
        """The last probe's reading while it serves (:data:`PROBE_AGAIN_AFTER` frames), else None."""
        return self.probe_reading if self.frames_since_probe < PROBE_AGAIN_AFTER else None

    def learn_probe(self, reading: float | None) -> None:
        """Count a frame, and keep ``reading`` when the frame probed (not None)."""
        if reading is not None:
            self.probe_reading, self.frames_since_probe = reading, 0
        self.frames_since_probe += 1

    # the fewest seconds seen: a scene's first frame in a process compiles kernels and loads the generator
    def learn_path(self, seconds_per_spp: float) -> None:
        self.seconds_per_spp = min(seconds_per_spp, self.seconds_per_spp or np.inf)

    def learn_extra(self, seconds: float) -> None:
        self.sparse_extra_seconds = min(seconds, self.sparse_extra_seconds or np.inf)


#: The fewest seconds per pixel the denoiser has taken in this process (first guess: OIDN on 2 cores, about
#: 0.06 s at 256x256 and 1.9 s at 1920x1080): what a time budget keeps back for the completion, and what a
#: budget's chooser counts in a dense frame. The fewest, as the first call in a process loads the denoiser.
_denoise_pace = {"seconds_per_pixel": 1.0e-6}


def completion_seconds(pixels: int) -> float:
    """Seconds the denoiser is expected to take on a frame of ``pixels`` pixels."""
    return _denoise_pace["seconds_per_pixel"] * pixels


def record_denoise(seconds: float, pixels: int) -> None:
    """Learn from a denoiser run of ``seconds`` on ``pixels`` pixels."""
    _denoise_pace["seconds_per_pixel"] = min(_denoise_pace["seconds_per_pixel"], seconds / max(pixels, 1))


def frame_costs(scene, pixels: int) -> FrameCosts:
    """The costs of ``scene`` at ``pixels`` pixels learnt so far in this process (kept in its
    :func:`~gmcpt.held.scene_state`, let go with the scene)."""
    return scene_state(scene).setdefault("costs", {}).setdefault(pixels, FrameCosts(pixels))
