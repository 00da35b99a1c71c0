"""Sequences: each frame traces its budget and reuses the samples of the frames before it (:mod:`gmcpt.temporal`).

    sequence = SequenceRenderer(SequenceSettings(budget=2))
    for index in range(24):
        scene = load_scene("anim.xml", params={"frame": index})
        image, info, timings = sequence.render(scene, index)

Per frame: guides (albedo, normal) and one ray through each pixel's centre (where it hits, to reproject);
the past frames reprojected (each straight into this one); this frame's samples placed where the history is
thin, so that disocclusions and the edge a pan uncovers get fresh samples first (every pixel gets one at
least, so the history can be checked against it); the history left out where it disagrees with them; then
OIDN over the sums; then the frame shown before, carried along the motion (Catmull-Rom, where the history
held), is blended into the denoised image, so that what OIDN leaves of the noise does not change every frame
(the flicker of :mod:`gmcpt.evaluation.stability`). A frame keeps its own samples only, for the frames after
it. :meth:`SequenceRenderer.state` and :meth:`SequenceRenderer.restore` carry the history across processes,
so a stopped sequence resumes with the images an uninterrupted run gives.

With no history (the first frame, after a cut), a frame is the budget's samples spread evenly, then OIDN.
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import asdict, dataclass

import drjit as dr
import mitsuba as mi
import numpy as np

from .budget import check_budget, even_fill, guide_spp
from .denoise import denoise_oidn
from .errors import GmcptError
from .frame import DEFAULT_FEATURE_SPP
from .limits import SEED_LIMIT, check_seed
from .render import SampleSums, _sensor_film_size, feature_means, render_native
from .scene import path_integrator, scene_sensor
from .temporal import (PastFrame, Projection, agreement, cubic_sample, fit_projection, history_weights, matches,
                       surfaces)

#: Frames of history kept by default, and the weight of a frame's samples per frame of age (0.9 over 0.8: +0.1-0.2
#: dB on a pan; 16 frames another +0.1 for twice the reprojection time; docs/experiments.md).
HISTORY_FRAMES = 8
HISTORY_DECAY = 0.9
#: A frame's sampler seeds: ``seed + index * FRAME_SEED_STEP`` (a frame draws samples of its own).
FRAME_SEED_STEP = 0x9E37
#: History counts are levelled up to this many times the budget: pixels with less (disocclusions, the edge a pan
#: uncovers) get fresh samples first, the others an even share (levelling up to 4x lost 0.5-1 dB on a still
#: camera: the noise OIDN sees grows uneven).
FRESH_CAP = 1
#: The weight of the frame shown before in each shown frame (an exponential moving average along the motion), up
#: to a budget of :data:`CARRY_FULL_BUDGET`, then falling as 1 / budget: at 1-2 samples a pixel 0.5 took a quarter
#: to a third off the flicker at -0.07 to +0.3 dB. At 4, 0.5 against 0.25 takes 3-12% more off the flicker and
#: costs the breakfast and living rooms 0.15-0.2 dB (the dining room nothing): what OIDN leaves there is mostly
#: error that stays, which carrying only resamples. Steadiness is what a sequence is for (docs/experiments.md).
SHOWN_CARRY = 0.5
CARRY_FULL_BUDGET = 4.0


@dataclass(frozen=True)
class SequenceSettings:
    """What a sequence traces a frame.

    Attributes
    ----------
    budget : path samples a pixel per frame (mean).
    seed : sampler seed of frame 0; frame i draws from ``seed + i * FRAME_SEED_STEP``.
    history : past frames kept (0: every frame on its own).
    decay : weight of a past frame's samples per frame of age, in (0, 1].
    """

    budget: float = 2.0
    seed: int = 0
    history: int = HISTORY_FRAMES
    decay: float = HISTORY_DECAY

    def __post_init__(self):
        check_budget(self.budget)
        check_seed(self.seed)
        if not isinstance(self.history, int) or not 0 <= self.history <= 64:
            raise GmcptError(f"history must be a whole number of frames in [0, 64], got {self.history}")
        history_weights([1], self.decay)

    def frame_seed(self, index: int) -> int:
        return (self.seed + index * FRAME_SEED_STEP) % SEED_LIMIT


def centre_rays(sensor: mi.Sensor) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(film coordinates (N, 2), origins (N, 3), directions (N, 3)) of one ray through each pixel's centre."""
    height, width = _sensor_film_size(sensor)
    index = dr.arange(mi.UInt32, height * width)
    film = mi.Point2f(mi.Float(index % width) + 0.5, mi.Float(index // width) + 0.5)
    ray, _ = sensor.sample_ray(time=sensor.shutter_open(), sample1=0.0,
                               sample2=film / mi.ScalarVector2f(width, height), sample3=mi.Point2f(0.5))
    rays = height * width  # a camera whose rays share an origin or a direction gives one lane of it
    return (np.stack([np.asarray(film.x), np.asarray(film.y)], axis=1).astype(np.float64),
            np.broadcast_to(_columns(ray.o), (rays, 3)), np.broadcast_to(_columns(ray.d), (rays, 3)))


def geometry(scene: mi.Scene, sensor: mi.Sensor) -> tuple[np.ndarray, np.ndarray, Projection]:
    """Where each pixel's centre ray hits (N, 3; NaN on a miss), the shading normal there (N, 3), and the
    camera's :class:`~gmcpt.temporal.Projection`."""
    height, width = _sensor_film_size(sensor)
    film, origins, directions = centre_rays(sensor)
    ray = mi.Ray3f(mi.Point3f(*origins.T.astype(np.float32)), mi.Vector3f(*directions.T.astype(np.float32)))
    hit = scene.ray_intersect(ray)
    dr.eval(hit.p, hit.sh_frame.n, hit.t)
    valid = np.asarray(hit.is_valid())
    # float32, as traced: the reprojection of 8 past frames reads them every frame, at half float64's traffic
    positions = np.where(valid[:, None], _columns(hit.p, np.float32), np.float32(np.nan))
    normals = np.where(valid[:, None], _columns(hit.sh_frame.n, np.float32), np.float32(np.nan))
    rows, columns = np.meshgrid(np.linspace(0, height - 1, 8).astype(np.int64),
                                np.linspace(0, width - 1, 8).astype(np.int64), indexing="ij")
    picks = (rows * width + columns).ravel()  # a grid of rays, not a line of them: 11 numbers to fit
    return positions, normals, fit_projection(film[picks], origins[picks], directions[picks], width, height)


def _columns(vector, dtype=np.float64) -> np.ndarray:
    """A Dr.Jit 3-vector of N lanes as (N, 3) ``dtype``."""
    return np.stack([np.asarray(vector.x), np.asarray(vector.y), np.asarray(vector.z)], axis=1).astype(dtype,
                                                                                                     copy=False)


class SequenceRenderer:
    """Renders the frames of a sequence in order, keeping the last :attr:`SequenceSettings.history` frames'
    samples (:class:`~gmcpt.temporal.PastFrame`)."""

    def __init__(self, settings: SequenceSettings = SequenceSettings()):
        self.settings = settings
        self.past: deque[PastFrame] = deque(maxlen=max(settings.history, 1))
        self.shown: tuple[int, np.ndarray] | None = None  # (frame, image) of the last frame shown

    def render(self, scene: mi.Scene, index: int, integrator: mi.SamplingIntegrator | None = None,
               sensor: mi.Sensor | None = None) -> tuple[np.ndarray, dict, dict]:
        """Frame ``index`` of ``scene``: (image (H, W, 3) float32, info, timings in seconds)."""
        settings = self.settings
        sensor = sensor if sensor is not None else scene_sensor(scene)
        integrator = integrator if integrator is not None else path_integrator(scene)
        height, width = _sensor_film_size(sensor)
        pixels, seed, timings = height * width, settings.frame_seed(index), {}

        start = time.perf_counter()
        guide_rays = guide_spp(settings.budget, DEFAULT_FEATURE_SPP)
        guides = feature_means(scene, sensor, guide_rays, seed, visibility=False).buffers()
        positions, normals, projection = geometry(scene, sensor)
        timings["features_s"] = time.perf_counter() - start

        start = time.perf_counter()
        history_total, history_count, latest_seen, latest_film = self._history(index, positions, normals, pixels)
        samples = int(round(settings.budget * pixels))
        counts = _placement(history_count, samples, settings.budget, (height, width), seed)
        timings["placement_s"] = time.perf_counter() - start

        start = time.perf_counter()
        sums, level = SampleSums(pixels), int(counts.min())
        if level:
            sums.add_native(render_native(scene, sensor, integrator, level, seed), level)
        if (counts > level).any():
            sums.trace_counts(scene, sensor, integrator, counts - level, (seed + 1) % SEED_LIMIT)
        total, count = sums.total, sums.finite  # NaN/Inf samples left out
        timings["render_s"] = time.perf_counter() - start

        start = time.perf_counter()
        own = total / np.maximum(count, 1)[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            past_mean = history_total / history_count[:, None]
        agrees = agreement(own.reshape(height, width, 3), np.nan_to_num(past_mean).reshape(height, width, 3),
                           (history_count > 0).reshape(height, width)).ravel()
        kept = np.where(agrees, history_count, 0.0)
        image = (total + history_total * agrees[:, None]) / np.maximum(count + kept, 1e-9)[:, None]
        timings["combine_s"] = time.perf_counter() - start

        start = time.perf_counter()
        denoised = denoise_oidn(image.reshape(height, width, 3).astype(np.float32), guides["albedo"], guides["normal"],
                                guide_rays)
        timings["denoise_s"] = time.perf_counter() - start

        start = time.perf_counter()
        shown, carried = self._carried(denoised, latest_film, latest_seen & agrees)
        timings["carry_s"] = time.perf_counter() - start

        if settings.history:
            # float32, as the samples were traced: 8 past frames' gathers a frame at half float64's traffic
            self.past.append(PastFrame(index, total.astype(np.float32), count.astype(np.float32), positions, normals,
                                       projection))
            self.shown = (index, shown)
        info = {"frame": index, "seed": seed, "budget": settings.budget, "path_samples": int(counts.sum()),
                "history_frames": len(self.past) - 1 if settings.history else 0,
                "history_pixels": float((kept > 0).mean()), "history_samples": float(kept.mean()),
                "history_dropped": float(((history_count > 0) & ~agrees).mean()), "carried_pixels": carried,
                "nonfinite_samples": int(sums.samples - count.sum()), "guide_rays": guide_rays}
        return shown, info, timings

    def _history(self, index: int, positions: np.ndarray, normals: np.ndarray,
                 pixels: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The past frames' samples reprojected into this frame, weighted by age: (sums (N, 3), counts (N,)); and
        where the frame last shown saw this frame's surfaces (N,) bool, with where they landed on its film (N, 2)."""
        summed, latest_seen = np.zeros((pixels, 4), np.float32), np.zeros(pixels, bool)
        latest_film = np.zeros((pixels, 2), np.float32)
        usable = [past for past in self.past if past.index < index and past.total.shape[0] == pixels]
        weights = history_weights([index - past.index for past in usable], self.settings.decay)
        current = surfaces(positions, normals)
        for past, weight in zip(usable, weights):
            seen, source, film = matches(past, current)
            # a gather over every pixel (the unmatched read a zero row), not a scatter into the matched ones:
            # half the time
            rows = np.full(pixels, pixels, np.int32)
            rows[seen] = source
            summed += past.gatherable[rows] * np.float32(weight)
            if self.shown is not None and past.index == self.shown[0]:
                latest_seen[seen], latest_film[seen] = True, film
        return summed[:, :3], summed[:, 3], latest_seen, latest_film

    def _carried(self, denoised: np.ndarray, film: np.ndarray, where: np.ndarray) -> tuple[np.ndarray, float]:
        """(the image to show: ``denoised`` (H, W, 3) with some of the frame shown before (:data:`SHOWN_CARRY`),
        read along the motion at ``film`` (N, 2, its film coordinates) where ``where`` (N,) says its surface was
        seen and its history held; the share of pixels blended)."""
        if self.shown is None or not where.any():
            return denoised, 0.0
        carry = SHOWN_CARRY * min(1.0, CARRY_FULL_BUDGET / self.settings.budget)
        flat = denoised.reshape(-1, 3).copy()
        flat[where] = (1 - carry) * flat[where] + carry * cubic_sample(self.shown[1], film[where])
        return flat.reshape(denoised.shape), float(where.mean())

    def state(self) -> dict:
        """The history as plain arrays (for :func:`numpy.savez`): what :meth:`restore` takes back."""
        state = {"settings": np.array(repr(sorted(asdict(self.settings).items())))}
        for slot, past in enumerate(self.past):
            for name in ("total", "count", "positions", "normals"):
                state[f"{slot}_{name}"] = getattr(past, name)
            state[f"{slot}_index"] = np.array(past.index)
            state[f"{slot}_matrix"] = past.projection.matrix
            state[f"{slot}_size"] = np.array([past.projection.width, past.projection.height])
        if self.shown is not None:
            state["shown_index"], state["shown"] = np.array(self.shown[0]), self.shown[1]
        return state

    def restore(self, state) -> None:
        """Take back a :meth:`state` of a run with the same settings; one-line error otherwise."""
        if str(state["settings"]) != repr(sorted(asdict(self.settings).items())):
            raise GmcptError("the saved sequence state was made with other settings; start the sequence again")
        self.past.clear()
        slot = 0
        while f"{slot}_index" in state:
            width, height = (int(value) for value in state[f"{slot}_size"])
            self.past.append(PastFrame(int(state[f"{slot}_index"]), state[f"{slot}_total"], state[f"{slot}_count"],
                                       state[f"{slot}_positions"], state[f"{slot}_normals"],
                                       Projection(state[f"{slot}_matrix"], width, height)))
            slot += 1
        self.shown = (int(state["shown_index"]), state["shown"]) if "shown_index" in state else None


def _placement(history_count: np.ndarray, samples: int, budget: float, shape: tuple[int, int],
               seed: int) -> np.ndarray:
    """This frame's samples a pixel (flat int): one each where the budget allows, the rest levelling the
    history's counts (capped at :data:`FRESH_CAP` x the budget) as :func:`~gmcpt.budget.even_fill` does, so
    pixels without history come first."""
    pixels = history_count.size
    floor = 1 if samples >= pixels else 0
    history = np.minimum(np.floor(history_count), FRESH_CAP * budget).astype(np.int64).reshape(shape)
    base = np.full(shape, floor, np.int64)
    return (base + even_fill(history + base, samples - floor * pixels, seed)).ravel()
