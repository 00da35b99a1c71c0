"""Sequences: each frame traces its budget and reuses the samples of the frames before it
(:mod:`gmcpt.temporal.history`).

    sequence = SequenceRenderer(SequenceSettings(budget=2))
    for index in range(24):
        scene = load_scene("anim.xml", params={"frame": index})
        image, info, timings = sequence.render(scene, index)

Per frame: guides (albedo, normal) and one ray through each pixel's centre (where it hits, to reproject);
the past frames reprojected (each straight into this one); this frame's samples placed where the history is
thin, so that disocclusions and the edge a pan uncovers get fresh samples first (every pixel gets one at
least, so the history can be checked against it); with a still camera, the history weighed by the share of the
light that did not change, as the last frame's light probes traced again with their random numbers say
(:mod:`gmcpt.temporal.gradient`: one pixel in nine, within the budget); the history left out where it disagrees
with them; then OIDN over the sums; then the frame shown before, carried along the motion (Catmull-Rom, where the
history held), is blended into the denoised image, so that what OIDN leaves of the noise does not change every
frame (the flicker of :mod:`gmcpt.evaluation.stability`). A frame keeps its own samples only, for the frames after
it (a moving camera's by quarter of the pixel, so that the gather reads those within its pixel); a surface on a mesh
that moved is looked for where it was (:mod:`gmcpt.temporal.motion`). :meth:`SequenceRenderer.state` and
:meth:`SequenceRenderer.restore` carry the history across processes, so a stopped sequence resumes with the images an
uninterrupted run gives.

With no history (the first frame, after a cut), a frame is the budget's samples spread evenly, then OIDN.

A sequence's paths take :data:`LIGHT_SAMPLES` emitter samples at their first hit where the scene's integrator is
Mitsuba's plain ``path`` (:class:`~gmcpt.render.guided_path.GuidedPath`; the same image in expectation).
"""
from __future__ import annotations

import time
from collections import deque
from dataclasses import asdict, dataclass, replace

import mitsuba as mi
import numpy as np

from ..errors import GmcptError
from ..frame import DEFAULT_FEATURE_SPP, FrameInfo, SparseFrame
from ..image.denoise import denoise_oidn
from ..limits import SEED_LIMIT, check_seconds, check_seed
from ..render.guided_path import twin_of
from ..render.kernels import SampleSums, box_filter, render_native, render_native_quarters, sensor_film_size
from ..render.scene import path_integrator, scene_sensor
from ..sampling.budget import MAX_BUDGET, check_budget, even_fill, guide_spp
from ..sampling.masks import DEFAULT_RATE
from ..seeds import (FRAME_SEED_STEP, SEQUENCE_PASS_SEED_OFFSET, SEQUENCE_PROBE_SEED_OFFSET,
                     SEQUENCE_TOP_UP_SEED_OFFSET, stream)
from .gradient import Probe, changed_share, coherent_share, probe_pixels, same_camera
from .history import (LIGHTING_FLOOR, SHIFT_SEEN, PastFrame, Projection, Signature, agreement, history_weights,
                      signature)
from .motion import ShapePoses, points_then, shape_keys
from .pace import TIMED_BUDGETS, FramePace
from .reprojection import JitFrame, cubic_sample, gather_history, jit_frame
from .survey import Survey, survey

#: Frames of history kept by default, and the weight of a frame's samples per frame of age (0.9 over 0.8: +0.1-0.2
#: dB on a pan; 16 frames another +0.1 for twice the reprojection time; docs/experiments.md).
HISTORY_FRAMES = 8
HISTORY_DECAY = 0.9
#: History counts are levelled up to this many times the budget: pixels with less (disocclusions, the edge a pan
#: uncovers) get fresh samples first, the others an even share (levelling up to 4x lost 0.5-1 dB on a still
#: camera: the noise OIDN sees grows uneven).
FRESH_CAP = 1
#: A surface pixel with less history than this (weighted samples) has none to speak of, and gets
#: :data:`FRESH_BOOST` x the budget more fresh samples, taken from the pixels with history: what changed (a moved
#: object, its shadow, a disocclusion) is where a sequence's frame is behind a frame on its own (docs/experiments.md).
FRESH_THIN = 0.5
FRESH_BOOST = 1.0
#: Where less than this share of the pixels' light changed frame-wide (nothing but objects moved), the last frame's
#: probes saw the moved objects' own pixels and shadows, and the light keeps changing there: the history there counts
#: as (the share of its light that held)^:data:`HELD_PLACEMENT_POWER` when this frame's samples are placed, so those
#: pixels get fresh samples first (8 over 2: the living object 1.89x -> 1.96x, the breakfast object 3.14x -> 3.38x;
#: docs/experiments.md, sixty-fifth session).
STEADY_LIGHT = 0.02
HELD_PLACEMENT_POWER = 8.0
#: ... and the history's samples there weigh (that share)^this, not the share itself: a moved table's drifting floor
#: reflection kept three quarters of its stale history at power 1 (the living object 1.93x -> 2.15x, seed 4 1.87x ->
#: 2.06x; the breakfast and dining objects within 1%; docs/experiments.md, sixty-fifth session).
HELD_HISTORY_POWER = 4.0
#: Where a light moved, the probes' unsigned share is mostly the noise of paths that changed at random (a boost from
#: it cost the dining and living lights 7-11%), so the placement reads what changed one way instead
#: (:func:`~gmcpt.temporal.gradient.coherent_share`): the history counts as (1 - that share)^this. It took the breakfast
#: room's turning sun from a ghost of -0.64 dB to -0.15 (three seeds' mean), 1.75x -> 1.9x, the other lights within 1-5%
#: (docs/experiments.md, sixty-fifth session).
LIGHT_PLACEMENT_POWER = 16.0
#: The history's decay falls with the share of the last frame's pixels whose light changed, to the power budget / this
#: (:attr:`SequenceRenderer.decay`): at budget 4 a shorter history took the breakfast room's turning sun's changed
#: pixels up 0.6 dB (its ghost -0.35 -> -0.15 dB), the dining light 2.68x -> 2.80x, the living light 2.92x -> 2.86x
#: (docs/experiments.md, sixty-fifth session).
LIGHT_DECAY_BUDGET = 2.0
#: The weight of the frame shown before in each shown frame (an exponential moving average along the motion), up
#: to a budget of :data:`CARRY_FULL_BUDGET`, then falling as 1 / budget: at 1-2 samples a pixel 0.5 took a quarter
#: to a third off the flicker at -0.07 to +0.3 dB. At 4, 0.5 against 0.25 takes 3-12% more off the flicker and
#: costs the breakfast and living rooms 0.15-0.2 dB (the dining room nothing): what OIDN leaves there is mostly
#: error that stays, which carrying only resamples. Steadiness is what a sequence is for (docs/experiments.md).
SHOWN_CARRY = 0.5
CARRY_FULL_BUDGET = 4.0
#: ... times (1 - the share of pixels whose light changed) to this power: where a light moves, the light it brings
#: to the rest changes too, unseen, and the image shown before is stale there (docs/experiments.md).
CARRY_LIGHT_POWER = 2.0
#: ... or, where the probes replayed (:mod:`gmcpt.temporal.gradient`), the share of a pixel's own light that held, to
#: this power, where that is more: the frame-wide share holds the carry back over the whole film, and a pixel whose
#: light the probes saw stay keeps its carry (the three light sequences' flicker 3-5% lower, their speed-ups within
#: 0.04x; docs/experiments.md, sixty-fourth session).
CARRY_HELD_POWER = 4.0
#: From this budget the carry also falls with how far off a past pixel's centre the image shown before is read, to
#: none at half a pixel: a Catmull-Rom read there blurs, and carried frame after frame the blur stays. At 4 samples a
#: pixel that took 0.1-0.35 dB off the pans; at 1 and 2, where noise outweighs blur, the full carry is steadier.
CARRY_FADE_BUDGET = 4.0
#: Emitter samples at each path's first hit (:class:`~gmcpt.render.guided_path.GuidedPath`): nearly all of a sunlit
#: pixel's noise is its direct light's choice of the sun or the sky, which history cannot average where the sun moves
#: or an object uncovers; 8 over 4 bought the sunsky's room a fifth more speed (docs/experiments.md, sixty-third
#: session).
LIGHT_SAMPLES = 8
#: Frames of up to this many pixels keep their samples by quarter of the pixel (16 floats a pixel: 4 MB at 256x256,
#: 8 past frames and their Dr.Jit copies 70 MB; at 1920x1080 that would be 2 GB), which a moving camera's history
#: reads (:mod:`gmcpt.temporal.reprojection`); larger ones, and frames traced by Mitsuba's film, are read by pixel.
QUARTER_PIXELS = 1 << 19


@dataclass(frozen=True)
class SequenceSettings:
    """What a sequence traces a frame.

    Attributes
    ----------
    budget : path samples a pixel per frame (mean).
    seed : sampler seed of frame 0; frame i draws from ``seed + i * FRAME_SEED_STEP``.
    history : past frames kept (0: every frame on its own).
    decay : weight of a past frame's samples per frame of age, in (0, 1].
    time : seconds a frame, from one frame's end to the next's (0: none, every frame spends ``budget``). With a
        time, ``budget`` is the first frame's, and each later frame's is read from the pace of the ones before
        (:class:`FramePace`), and its path tracing stops at the frame's deadline (:meth:`FramePace.deadline`); the guides
        keep ``budget``'s rays, so a still surface keeps its signature.
    light_samples : emitter samples at each path's first hit (1: Mitsuba's ``path`` to the bit); an integrator other
        than a plain ``path`` traces as it is.
    """

    budget: float = 2.0
    seed: int = 0
    history: int = HISTORY_FRAMES
    decay: float = HISTORY_DECAY
    time: float = 0.0
    light_samples: int = LIGHT_SAMPLES

    def __post_init__(self):
        check_budget(self.budget)
        check_seed(self.seed)
        if self.time:
            check_seconds(self.time, "time")
        if not isinstance(self.history, int) or not 0 <= self.history <= 64:
            raise GmcptError(f"history must be a whole number of frames in [0, 64], got {self.history}")
        history_weights([1], self.decay)
        if not isinstance(self.light_samples, int) or not 1 <= self.light_samples <= 64:
            raise GmcptError(f"light samples must be a whole number in [1, 64], got {self.light_samples}")

    def frame_seed(self, index: int) -> int:
        return (self.seed + index * FRAME_SEED_STEP) % SEED_LIMIT


@dataclass(frozen=True)
class DroppedShares:
    """The shares of pixels whose history was dropped, a reason (:attr:`SequenceRecord.dropped`).

    Attributes
    ----------
    lighting : the lighting signature changed. material : the material signature changed.
    unseen : no past frame saw the pixel's surface (0 without past frames).
    disagreement : kept history that disagreed with this frame's samples
        (:func:`~gmcpt.temporal.history.agreement`).
    gradient : not a share of pixels but of the history's weighted samples: those left out where the probes saw
        the light change (:mod:`gmcpt.temporal.gradient`).
    """

    lighting: float
    material: float
    unseen: float
    disagreement: float = 0.0
    gradient: float = 0.0

    def to_json(self) -> dict:
        """The sidecar's ``dropped`` entry, in its order."""
        return {"lighting": self.lighting, "material": self.material, "unseen": self.unseen,
                "disagreement": self.disagreement, "gradient": self.gradient}


@dataclass(frozen=True)
class History:
    """What the past frames give the current one (:meth:`SequenceRenderer._history`), flat over its pixels."""

    total: np.ndarray  # (N, 3) weighted sums of the samples kept
    count: np.ndarray  # (N,) their weighted count
    offered: np.ndarray  # (N,) bool: some past frame saw the pixel's surface
    latest_seen: np.ndarray  # (N,) bool: the frame shown last saw it, unchanged
    latest_film: np.ndarray  # (N, 2) where on that frame's film
    frames: int  # past frames used
    dropped: DroppedShares  # the shares of pixels that lost a past frame's samples, a reason (disagreement: 0 here)
    light_held: np.ndarray | None = None  # (N,) the share of each pixel's light that held, as the probes saw it

    def scaled(self, held: np.ndarray, power: float = 1.0) -> History:
        """This history with each pixel's samples weighted by ``held`` (N,), the share of its light that held
        (:attr:`light_held`), to ``power``, what it left out recorded (:attr:`DroppedShares.gradient`)."""
        held = np.asarray(held, self.count.dtype)
        keep = held ** self.count.dtype.type(power) if power != 1.0 else held
        count = self.count * keep
        before = float(self.count.sum(dtype=np.float64))
        left_out = 1.0 - float(count.sum(dtype=np.float64)) / before if before > 0 else 0.0
        return replace(self, total=self.total * keep[:, None], count=count, light_held=held,
                       dropped=replace(self.dropped, gradient=left_out))


@dataclass(frozen=True)
class SequenceRecord:
    """What a sequence frame records of how it was made (:meth:`SequenceRenderer.render_frame`); a single frame's
    layers carry it as :attr:`gmcpt.frame.FrameInfo.sequence`. :meth:`to_json` gives the frame's entries of the
    sidecar.

    Attributes
    ----------
    frame : the frame's index. seed : its samples' seed (:meth:`SequenceSettings.frame_seed`).
    budget : the samples a pixel it spent (a timed sequence's: read from the pace of the frames before).
    path_samples : samples traced; nonfinite_samples : those that were NaN/Inf (left out).
    history_frames : past frames used. history_decay : the weight of their samples per frame of age
        (:attr:`SequenceRenderer.decay`). history_pixels : the share of pixels that kept some history;
        history_samples : the weighted history samples kept, a pixel; history_dropped : the share of pixels whose
        past frames saw their surface but whose history was left out.
    dropped : the shares of pixels that lost a past frame's samples, a reason (:class:`DroppedShares`).
    carried_pixels : the share of pixels blended with the frame shown before (:data:`SHOWN_CARRY`).
    guide_rays : the guides' rays a pixel. light_samples : the emitter samples each path took at its first hit.
    time_short : a timed sequence's: whether its time bought the fewest samples a frame spends
        (:data:`TIMED_BUDGETS`) or fewer; None: not timed.
    """

    frame: int
    seed: int
    budget: float
    path_samples: int
    history_frames: int
    history_decay: float
    history_pixels: float
    history_samples: float
    history_dropped: float
    dropped: DroppedShares
    carried_pixels: float
    nonfinite_samples: int
    guide_rays: int
    light_samples: int = 1
    time_short: bool | None = None

    def to_json(self) -> dict:
        """The frame's entries of the sidecar JSON, in its order (its seed is one of the sidecar's parameters, so
        not here; ``time_short`` only where timed)."""
        return {"frame": self.frame, "budget": self.budget, "path_samples": self.path_samples,
                "history_frames": self.history_frames, "history_decay": self.history_decay,
                "history_pixels": self.history_pixels,
                "history_samples": self.history_samples, "history_dropped": self.history_dropped,
                "dropped": self.dropped.to_json(), "carried_pixels": self.carried_pixels,
                "nonfinite_samples": self.nonfinite_samples, "guide_rays": self.guide_rays,
                "light_samples": self.light_samples,
                **({"time_short": self.time_short} if self.time_short is not None else {})}


@dataclass(frozen=True)
class SequenceFrame:
    """One frame of a sequence: the image shown (H, W, 3) float32; its layers as a single frame's
    (:class:`~gmcpt.frame.SparseFrame`: the samples' mean, this frame's and the history's, where there were any;
    the guides); the frame's figures (:class:`SequenceRecord`: history kept and dropped, samples) and its stage
    timings in seconds."""

    image: np.ndarray
    layers: SparseFrame
    info: SequenceRecord
    timings: dict


def _layers(mean: np.ndarray, count: np.ndarray, guides: dict, budget: float, info: SequenceRecord) -> SparseFrame:
    """The :class:`~gmcpt.frame.SparseFrame` of a sequence frame: ``mean`` (N, 3) of ``count`` (N,) weighted
    samples, this frame's and the history's, and the survey's ``guides``; no variance is kept (zeros); ``info``: the
    sequence frame's record (:attr:`gmcpt.frame.FrameInfo.sequence`)."""
    height, width = guides["albedo"].shape[:2]
    sampled = (count > 0).reshape(height, width)
    radiance = np.where(sampled[..., None], mean.reshape(height, width, 3), 0.0).astype(np.float32)
    return SparseFrame(radiance=radiance, mask=sampled, variance=np.zeros((height, width), np.float32),
                       albedo=guides["albedo"], normal=guides["normal"], depth=guides["depth"],
                       visibility=guides["visibility"], spp=max(1, round(budget)), coverage=guides["coverage"],
                       info=FrameInfo(sequence=info))


class SequenceRenderer:
    """Renders the frames of a sequence in order, keeping the last :attr:`SequenceSettings.history` frames'
    samples (:class:`~gmcpt.temporal.history.PastFrame`)."""

    def __init__(self, settings: SequenceSettings = SequenceSettings()):
        self.settings = settings
        self.past: deque[PastFrame] = deque(maxlen=max(settings.history, 1))
        self.shown: tuple[int, np.ndarray] | None = None  # (frame, image) of the last frame shown
        self._jit: dict[int, tuple[PastFrame, JitFrame]] = {}  # the past frames in Dr.Jit, by id
        self.pace = FramePace()  # what the frames so far cost: a timed sequence's budgets
        self.light_changed = 0.0  # the share of the last frame's pixels whose light changed (DroppedShares.lighting)
        self.probe: Probe | None = None  # the last frame's probe (:mod:`gmcpt.temporal.gradient`)
        self.placing: np.ndarray | None = None  # (N,) what the next placement weighs the history's counts by
        self.poses = ShapePoses()  # the meshes that moved (:mod:`gmcpt.temporal.motion`)

    def render(self, scene: mi.Scene, index: int, integrator: mi.SamplingIntegrator | None = None,
               sensor: mi.Sensor | None = None) -> tuple[np.ndarray, SequenceRecord, dict]:
        """Frame ``index`` of ``scene``: (image (H, W, 3) float32, its :class:`SequenceRecord`, timings in seconds)."""
        frame = self.render_frame(scene, index, integrator, sensor)
        return frame.image, frame.info, frame.timings

    def render_frame(self, scene: mi.Scene, index: int, integrator: mi.SamplingIntegrator | None = None,
                     sensor: mi.Sensor | None = None) -> SequenceFrame:
        """Frame ``index`` of ``scene`` with its layers (:class:`SequenceFrame`)."""
        settings = self.settings
        started = time.perf_counter()
        budget = self.pace.budget(settings.time, settings.budget) if settings.time else settings.budget
        sensor = sensor if sensor is not None else scene_sensor(scene)
        integrator = integrator if integrator is not None else path_integrator(scene)
        tracer = (twin_of(scene, integrator, settings.light_samples, features=False)
                  if settings.light_samples > 1 else None) or integrator
        height, width = sensor_film_size(sensor)
        pixels, seed, timings = height * width, settings.frame_seed(index), {}

        start = time.perf_counter()
        guide_rays = guide_spp(settings.budget, DEFAULT_FEATURE_SPP)
        # one seed: a still camera's survey stays put
        found = survey(scene, sensor, guide_rays, settings.seed)
        albedo = (found.features.planes[0] + found.features.planes[1] + found.features.planes[2]) / np.float32(3)
        marks = signature(found.lighting, albedo, width, height)
        guides = found.features.buffers()
        timings["features_s"] = time.perf_counter() - start

        start = time.perf_counter()
        poses = self.poses.update(scene) if settings.history else {}
        history = self._history(index, found, marks, _moved_lanes(scene, found.shapes, poses), poses)
        deadline = self.pace.deadline(settings.time, started) if settings.time else None
        if deadline is not None:  # what the frame's first part left of its time: the samples it places are those
            budget = min(budget, self.pace.budget_until(deadline, start))
        samples = int(round(budget * pixels))
        counts = _placement(_placed_history(history.count, self.placing), samples, budget, (height, width), seed,
                            np.isfinite(found.positions[:, 0]))
        probes, replayed = self._probes(index, found.projection.matrix, (height, width), seed, history) \
            if settings.history and not settings.time else ({}, None)
        for pixels_ahead, _ in probes.values():  # their sample comes from the probe or its replay, within the budget
            counts[pixels_ahead] = np.maximum(counts[pixels_ahead] - 1, 0)
        timings["placement_s"] = time.perf_counter() - start

        start = time.perf_counter()
        sums = SampleSums(pixels, quarters=self._keeps_quarters(sensor, found.projection))
        slots = sorted(probes)
        probed = dict(zip(slots, _trace(sums, (scene, sensor, tracer), counts, seed, deadline,
                                        timed=bool(settings.time), ahead=[probes[slot] for slot in slots])))
        history = self._probed(history, probes, probed, replayed, index, found.projection.matrix, (height, width))
        total, count = sums.total, sums.finite  # NaN/Inf samples left out
        traced = time.perf_counter()
        timings["render_s"] = traced - start
        budget = sums.samples / pixels if deadline is not None else budget  # what the deadline let it trace

        start = time.perf_counter()
        own = total / np.maximum(count, 1)[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            past_mean = history.total / history.count[:, None]
        agrees = agreement(own.reshape(height, width, 3), np.nan_to_num(past_mean).reshape(height, width, 3),
                           (history.count > 0).reshape(height, width)).ravel()
        kept = np.where(agrees, history.count, 0.0)
        image = (total + history.total * agrees[:, None]) / np.maximum(count + kept, 1e-9)[:, None]
        timings["combine_s"] = time.perf_counter() - start

        start = time.perf_counter()
        denoised = denoise_oidn(image.reshape(height, width, 3).astype(np.float32), guides["albedo"], guides["normal"],
                                guide_rays)
        timings["denoise_s"] = time.perf_counter() - start

        start = time.perf_counter()
        shown, carried = self._carried(denoised, history.latest_film, history.latest_seen & agrees, budget,
                                       history.dropped.lighting, history.light_held)
        timings["carry_s"] = time.perf_counter() - start

        if settings.history:
            start = time.perf_counter()
            # float32, as the samples were traced: 8 past frames' gathers a frame at half float64's traffic
            self.past.append(PastFrame(index, total.astype(np.float32), count.astype(np.float32), found.positions,
                                       found.normals, found.projection, marks,
                                       sums.quarters, poses))  # float32 already, and this frame's own
            self.shown = (index, shown)
            timings["keep_s"] = time.perf_counter() - start
        decay, self.light_changed = self.decay, history.dropped.lighting  # the decay this frame's history had
        dropped = replace(history.dropped, disagreement=float(((history.count > 0) & ~agrees).mean()))
        info = SequenceRecord(frame=index, seed=seed, budget=budget, path_samples=sums.samples,
                              history_frames=history.frames, history_decay=decay,
                              history_pixels=float((kept > 0).mean()),
                              history_samples=float(kept.mean()),
                              history_dropped=float((history.offered & ~((history.count > 0) & agrees)).mean()),
                              dropped=dropped, carried_pixels=carried,
                              nonfinite_samples=int(sums.samples - count.sum()), guide_rays=guide_rays,
                              light_samples=getattr(tracer, "light_samples", 1),
                              time_short=budget <= TIMED_BUDGETS[0] if settings.time else None)
        if settings.time:  # only a timed sequence reads its pace (what follows falls in the next frame's period)
            self.pace.record(started, time.perf_counter(), timings["render_s"], budget, settings.time, traced)
        layers = _layers(image, count + kept, guides, budget, info)
        return SequenceFrame(shown, layers, info, timings)

    def _keeps_quarters(self, sensor: mi.Sensor, projection: Projection) -> bool:
        """Whether this frame keeps its samples by quarter of the pixel (:func:`keeps_quarters`): only a moving
        camera's history reads them, so not where the camera stayed since the frame before (a still camera's frames
        are then the same bits as without quarters), nor in a timed sequence or one without history."""
        still = bool(self.past) and same_camera(self.past[-1].projection.matrix, projection.matrix)
        return bool(self.settings.history) and not self.settings.time and not still and keeps_quarters(sensor)

    def _history(self, index: int, found: Survey, marks: Signature, lanes: dict[int, np.ndarray],
                 poses: dict[int, np.ndarray]) -> History:
        """The past frames' samples reprojected into this frame (``found``: its :func:`survey`; ``marks``: its
        :class:`~gmcpt.temporal.history.Signature`), weighted by age, where each past pixel saw the same surface under
        the same light and material (:func:`~gmcpt.temporal.history.unchanged`); a point on a mesh that moved (its
        pixels in ``lanes``, its pose in ``poses``, :mod:`gmcpt.temporal.motion`) looked for where it was."""
        shape = found.features.shape
        usable = [past for past in self.past
                  if past.index < index and (past.projection.height, past.projection.width) == shape]
        weights = history_weights([index - past.index for past in usable], self.decay)
        hits = found.lighting[np.isfinite(found.positions[:, 0])]
        floor = LIGHTING_FLOOR * float(hits.mean()) if hits.size else 0.0
        latest = self.shown[0] if self.shown is not None else None
        # a camera that moved by whole pixels lands on the past centres as a still one does (reprojection._match)
        frames = [(self._jit_frame(past), weight, past.index == latest,
                   not same_camera(past.projection.matrix, found.projection.matrix),
                   points_then(found.positions, found.normals, lanes, poses, past.poses or {}))
                  for past, weight in zip(usable, weights)]
        gathered = gather_history(frames, found.positions, found.normals, marks, floor)
        shares = DroppedShares(
            lighting=float(gathered.lighting_dropped.mean()), material=float(gathered.material_dropped.mean()),
            unseen=float((~gathered.offered & np.isfinite(found.positions[:, 0])).mean()) if usable else 0.0)
        # where on the latest frame's film (zero where not seen): the carry reads the image it showed
        return History(gathered.summed[:, :3], gathered.summed[:, 3], gathered.offered, gathered.latest_seen,
                       gathered.latest_film, len(usable), shares)

    def _camera_stayed(self, index: int, matrix: np.ndarray) -> bool:
        """Whether frame ``index``'s camera (its projection ``matrix``) is where the frame before it had its own."""
        last = self.past[-1] if self.past else None
        return last is not None and last.index == index - 1 and same_camera(last.projection.matrix, matrix)

    def _probes(self, index: int, matrix: np.ndarray, shape: tuple[int, int], seed: int,
                history: History) -> tuple[dict[int, tuple[np.ndarray, int]], Probe | None]:
        """(the pixel groups this frame traces ahead of its samples, by slot ((flat pixels, seed) each;
        :mod:`gmcpt.temporal.gradient`): its own probe, and the last frame's again in the slot it had; that last
        probe, or None), where the camera stayed and there is history (a moved camera's probe would never replay; a
        frame without history, the first or a cut, is the single frame's render)."""
        if not (history.count > 0).any() or not self._camera_stayed(index, matrix):
            return {}, None
        last = self.probe if self.probe is not None and self.probe.replays_in(index, matrix, shape) else None
        probe_seed = stream(seed, SEQUENCE_PROBE_SEED_OFFSET)  # its pixels' choice and its samples
        pixels = probe_pixels(shape, probe_seed, last.pixels if last else None)
        if not pixels.size:  # a film smaller than a block
            return {}, None
        groups = {1 - last.slot if last is not None else 0: (pixels, probe_seed)}
        if last is not None:
            groups[last.slot] = (last.pixels, last.seed)
        return groups, last

    def _probed(self, history: History, probes: dict, probed: dict, replayed: Probe | None, index: int,
                matrix: np.ndarray, shape: tuple[int, int]) -> History:
        """``history`` weighed by the share of the light that did not change, where the last frame's probe
        ``replayed`` was traced again (``probed``: each slot's samples); this frame's probe kept for the next, and
        :attr:`placing`, what the next placement weighs the history's counts by, so that the pixels whose light keeps
        changing read as thin history and get fresh samples first. Where only objects moved (:data:`STEADY_LIGHT`),
        the probes saw them and their shadows: the history weighs the light held to :data:`HELD_HISTORY_POWER` and the
        placement reads it to :data:`HELD_PLACEMENT_POWER`. Where a light changed, the placement reads 1 - the share
        that changed one way (:func:`coherent_share`) to :data:`LIGHT_PLACEMENT_POWER`."""
        own = [slot for slot in probes if replayed is None or slot != replayed.slot]
        if own:
            pixels, probe_seed = probes[own[0]]
            self.probe = Probe(index, probe_seed, pixels, probed[own[0]], matrix, shape, own[0])
        if replayed is None:
            self.placing = None
            return history
        before, after = replayed.values, probed[replayed.slot]
        held = 1.0 - changed_share(before, after, shape)
        if history.dropped.lighting < STEADY_LIGHT:
            history = history.scaled(held, HELD_HISTORY_POWER)
            self.placing = history.light_held ** np.float32(HELD_PLACEMENT_POWER)
        else:
            history = history.scaled(held)
            self.placing = (1.0 - coherent_share(before, after, shape)) ** np.float32(LIGHT_PLACEMENT_POWER)
        return history

    @property
    def decay(self) -> float:
        """The weight of a past frame's samples per frame of age in the next frame: the settings' decay times the
        share of the last frame's pixels whose light held, to the power budget / :data:`LIGHT_DECAY_BUDGET`. Where the
        light changes over much of the frame (a sun that moves), the light it brings to the rest, which no signature
        sees, changes too, and older history is stale there; the more samples a frame traces, the less their noise
        hides that (docs/experiments.md)."""
        return self.settings.decay * (1.0 - self.light_changed) ** (self.settings.budget / LIGHT_DECAY_BUDGET)

    def _jit_frame(self, past: PastFrame) -> JitFrame:
        """``past`` in Dr.Jit, made once (kept while the frame is in the history)."""
        self._jit = {key: entry for key, entry in self._jit.items() if any(entry[0] is frame for frame in self.past)}
        if id(past) not in self._jit:  # the entry holds the frame itself, so no other frame takes its id meanwhile
            self._jit[id(past)] = (past, jit_frame(past))
        return self._jit[id(past)][1]

    def _carried(self, denoised: np.ndarray, film: np.ndarray, where: np.ndarray, budget: float,
                 light_changed: float, light_held: np.ndarray | None = None) -> tuple[np.ndarray, float]:
        """(the image to show: ``denoised`` (H, W, 3) with some of the frame shown before (:data:`SHOWN_CARRY`, less
        where ``light_changed`` of the pixels' light changed, unless ``light_held`` (N,) says a pixel's own light held
        (:data:`CARRY_HELD_POWER`), and from :data:`CARRY_FADE_BUDGET` less where it is read between its pixels), read
        along the motion at ``film`` (N, 2, its film coordinates) where ``where`` (N,) says its surface was seen and its
        history held; the share of pixels blended)."""
        height, width = denoised.shape[:2]
        # a point beyond the edge of the film shown before (held by its edge pixel) was not in that image
        where = where & (film[:, 0] >= 0) & (film[:, 0] <= width) & (film[:, 1] >= 0) & (film[:, 1] <= height)
        if self.shown is None or not where.any():
            return denoised, 0.0
        held = np.full(int(where.sum()), (1.0 - light_changed) ** CARRY_LIGHT_POWER, np.float32)
        if light_held is not None:
            held = np.maximum(held, light_held[where].astype(np.float32) ** np.float32(CARRY_HELD_POWER))
        carry = np.float32(SHOWN_CARRY * min(1.0, CARRY_FULL_BUDGET / budget)) * held
        if budget >= CARRY_FADE_BUDGET:
            off = film[where] - 0.5  # pixel centres at whole numbers
            off = np.abs(off - np.round(off)).max(axis=1)
            carry *= 1 - 2 * np.where(off >= SHIFT_SEEN, off, 0)  # a still camera's reads land on the centres
        flat = denoised.reshape(-1, 3).copy()
        flat[where] = (1 - carry[:, None]) * flat[where] + carry[:, None] * cubic_sample(self.shown[1], film[where])
        return flat.reshape(denoised.shape), float(where.mean())

    def state(self) -> dict:
        """The history as plain arrays (for :func:`numpy.savez`): what :meth:`restore` takes back. Each past frame's
        arrays (:meth:`PastFrame.arrays`) are named ``SLOT_NAME``, the rest's (:meth:`rest_state`) as they are."""
        state = self.rest_state()
        for slot, past in enumerate(self.past):
            state.update({f"{slot}_{name}": value for name, value in past.arrays().items()})
        return state

    def rest_state(self) -> dict:
        """The state but the past frames: the settings, the frame shown, the probe, the moving meshes' poses."""
        state = {"settings": np.array(repr(sorted(asdict(self.settings).items())))}
        if self.shown is not None:
            state["shown_index"], state["shown"] = np.array(self.shown[0]), self.shown[1]
        state["light_changed"] = np.array(self.light_changed)
        if self.placing is not None:
            state["placing"] = self.placing
        state.update(self.poses.state())
        if self.probe is not None:
            probe = self.probe
            state["probe_index"], state["probe_seed"] = np.array(probe.index), np.array(probe.seed)
            state["probe_pixels"], state["probe_values"] = probe.pixels, probe.values
            state["probe_matrix"], state["probe_shape"] = probe.matrix, np.array(probe.shape)
            state["probe_slot"] = np.array(probe.slot)
        return state

    def restore(self, state) -> None:
        """Take back a :meth:`state` of a run with the same settings; one-line error otherwise."""
        pasts, slot = [], 0
        while f"{slot}_index" in state:
            prefix = f"{slot}_"
            pasts.append({key[len(prefix):]: value for key, value in state.items() if key.startswith(prefix)})
            slot += 1
        self.restore_parts(pasts, state)

    def restore_parts(self, pasts: list, rest) -> None:
        """Take back the past frames' :meth:`PastFrame.arrays` (oldest first) and a :meth:`rest_state` of a run with
        the same settings; one-line error otherwise."""
        if str(rest["settings"]) != repr(sorted(asdict(self.settings).items())):
            raise GmcptError("the saved sequence state was made with other settings; start the sequence again")
        self.past.clear()
        self.past.extend(PastFrame.from_arrays(arrays) for arrays in pasts)
        self.poses.restore(rest, (self.past[-1].poses or {}) if self.past else {})
        self.shown = (int(rest["shown_index"]), rest["shown"]) if "shown_index" in rest else None
        self.light_changed = float(rest["light_changed"]) if "light_changed" in rest else 0.0
        self.placing = rest["placing"] if "placing" in rest else None
        self.probe = Probe(int(rest["probe_index"]), int(rest["probe_seed"]), rest["probe_pixels"],
                           rest["probe_values"], rest["probe_matrix"],
                           tuple(int(value) for value in rest["probe_shape"]),
                           int(rest["probe_slot"])) if "probe_index" in rest else None


def _moved_lanes(scene: mi.Scene, registry: np.ndarray, poses: dict) -> dict[int, np.ndarray]:
    """The pixels on each mesh that has moved (``poses``' keys: places in ``scene.shapes()``), from each pixel's
    registry index ``registry`` (:attr:`Survey.shapes`); none while no mesh has moved."""
    if not poses:
        return {}
    keys = shape_keys(scene)
    places = np.where(registry < keys.size, keys[np.minimum(registry, keys.size - 1)], -1)
    return {key: lanes for key in poses if (lanes := np.flatnonzero(places == key)).size}


def keeps_quarters(sensor: mi.Sensor) -> bool:
    """Whether a frame of ``sensor`` keeps its samples by quarter of the pixel: a box filter (each sample in its own
    pixel, as the pixel-list kernel sums them) and at most :data:`QUARTER_PIXELS` pixels."""
    height, width = sensor_film_size(sensor)
    return box_filter(sensor) and height * width <= QUARTER_PIXELS


def sequence_budget(budget: float | None, sensor: mi.Sensor) -> float:
    """A sequence's samples a pixel a frame: ``budget``, or by default as many as rate ``DEFAULT_RATE`` traces at
    the sensor's spp (what a single frame spends by default)."""
    return budget if budget else DEFAULT_RATE * sensor.sampler().sample_count()


class RenderLoop:
    """The frames of successive renders of one scene object, as ``mi.render`` gives them to ``masked_path``: each a
    frame of one sequence, reusing the ones before it (the camera and shapes may move through ``mi.traverse``
    between them). Another scene, another film size or :meth:`reset` starts a new sequence.

    Frame ``i`` draws the samples :class:`SequenceSettings` gives frame ``i``, so the frames equal those of
    ``gmcpt batch --frames 0:N --history H`` on a scene that moves the same way."""

    def __init__(self, budget: float | None, seed: int, history: int, seconds: float = 0.0):
        self.budget, self.seed, self.history, self.seconds = budget, seed, history, seconds
        SequenceSettings(budget=budget or 1.0, seed=seed, history=history, time=seconds)  # one line on a bad value
        self.reset()

    def reset(self) -> None:
        """Forget the frames so far: the next render is frame 0 of a new sequence."""
        self.renderer: SequenceRenderer | None = None
        self._held: tuple = ()
        self.next_index = 0

    def render(self, scene: mi.Scene, sensor: mi.Sensor, integrator: mi.SamplingIntegrator,
               index: int | None = None) -> SequenceFrame:
        """Frame ``index`` (default: the one after the last) of the sequence ``scene`` is in, started anew here
        for another scene or film size. The scene is known by its address: holding it would keep it alive."""
        held = (scene.ptr, sensor_film_size(sensor))
        if self.renderer is None or held != self._held:
            self.reset()
            self.renderer = SequenceRenderer(SequenceSettings(budget=sequence_budget(self.budget, sensor),
                                                              seed=self.seed, history=self.history,
                                                              time=self.seconds))
            self._held = held
        index = self.next_index if index is None else index
        frame = self.renderer.render_frame(scene, index, integrator, sensor)
        self.next_index = index + 1
        return frame


#: A timed frame's last pass, over a share of the pixels, costs this share of a whole pass besides its own share
#: (its launch): a tenth of a 128x128 frame's pixels took 0.28 of a whole pass, a quarter 0.43, half 0.66.
PARTIAL_LAUNCH = 0.2


def _trace(sums: SampleSums, where: tuple, counts: np.ndarray, seed: int, deadline: float | None,
           timed: bool, ahead: list[tuple[np.ndarray, int]] = ()) -> list[np.ndarray]:
    """Trace ``counts`` samples a pixel (flat) into ``sums`` (``where``: scene, sensor, integrator): the level every
    pixel gets through Mitsuba's own render, the rest a pixel-list pass. ``timed``: through the frozen kernel, which
    serves any spp (a timed sequence's level changes every frame, and ``mi.render`` compiles a kernel for each).
    With groups of pixels ``ahead`` ((pixels, seed) each), one sample of each goes ahead of the others in the
    pixel-list pass, which then traces every sample (one launch), and each group's samples are returned (probes,
    :mod:`gmcpt.temporal.gradient`).

    With a ``deadline`` (perf_counter) the level goes in passes of one sample a pixel: the first and the rest of
    ``counts`` always (every pixel's one sample checks its history; the pixels without history need theirs), then each
    further pass while the last one's seconds say it ends by the deadline, past the level too while there is time
    (a plan of less than a sample a pixel, read from frames that compiled their kernels, is made up for there),
    and what is left, less than a pass, on one sample of a share of the pixels (:data:`PARTIAL_LAUNCH`)."""
    scene, sensor, integrator = where
    level = 0 if ahead else int(counts.min())
    first = 1 if deadline is not None and level else level
    start = time.perf_counter()
    if first and sums.quarters is not None:
        image, quarters = render_native_quarters(scene, sensor, integrator, first, seed)
        sums.add_native(image, first, quarters)
    elif first:
        sums.add_native(render_native(scene, sensor, integrator, first, seed, any_size=timed), first)
    pass_seconds = time.perf_counter() - start
    probed = []
    if (counts > level).any() or ahead:
        start = time.perf_counter()
        probed = sums.trace_counts(scene, sensor, integrator, counts - level,
                                   stream(seed, SEQUENCE_TOP_UP_SEED_OFFSET), ahead)
        if not first:  # no whole pass timed yet: the pixel-list pass's seconds a sample, for every pixel (dearer)
            pass_seconds = (time.perf_counter() - start) * sums.size / max(int((counts - level).sum()), 1)
    if deadline is None:
        return probed
    passes = 1
    while sums.samples < MAX_BUDGET * sums.size and time.perf_counter() + pass_seconds <= deadline:
        start = time.perf_counter()
        sums.add_native(render_native(scene, sensor, integrator, 1, stream(seed, SEQUENCE_PASS_SEED_OFFSET + passes),
                                      any_size=True), 1)
        pass_seconds, passes = time.perf_counter() - start, passes + 1
    # what is left of the time, less than a pass, goes to one sample of as many pixels (spread) as it pays for
    share = ((deadline - time.perf_counter()) / max(pass_seconds, 1e-6) - PARTIAL_LAUNCH) / (1 - PARTIAL_LAUNCH)
    if 0 < share < 1 and sums.samples < MAX_BUDGET * sums.size:
        chosen = even_fill(np.zeros(sensor_film_size(sensor), np.int64), int(share * sums.size),
                           stream(seed, SEQUENCE_PASS_SEED_OFFSET + passes)).ravel()
        sums.trace_counts(scene, sensor, integrator, chosen, stream(seed, SEQUENCE_PASS_SEED_OFFSET + passes))
    return probed


def _placed_history(history_count: np.ndarray, placing: np.ndarray | None) -> np.ndarray:
    """The history's counts (N,) as the placement reads them: times ``placing`` (what
    :meth:`SequenceRenderer._probed` left for this frame; None: as they are)."""
    if placing is None or placing.size != history_count.size:
        return history_count
    return history_count * placing.astype(history_count.dtype)


def _placement(history_count: np.ndarray, samples: int, budget: float, shape: tuple[int, int], seed: int,
               surface: np.ndarray | None = None) -> np.ndarray:
    """This frame's samples a pixel (flat int): one each where the budget allows, the rest levelling the
    history's counts (capped at :data:`FRESH_CAP` x the budget) as :func:`~gmcpt.sampling.budget.even_fill` does, so
    pixels without history come first. Where some pixels have history, a pixel of ``surface`` (N,) bool (its centre
    ray hit) that has none (a disocclusion, an object that moved, light that changed) gets :data:`FRESH_BOOST` x the
    budget more, taken from the others."""
    pixels = history_count.size
    if surface is not None and (history_count > 0).any():
        thin = surface & (history_count < FRESH_THIN)
        boost = int(round(FRESH_BOOST * budget))
        if boost and thin.any():
            reserved = min(boost * int(thin.sum()), samples)
            counts = _placement(history_count, samples - reserved, budget, shape, seed)
            return counts + np.where(thin, reserved // int(thin.sum()), 0)
    floor = 1 if samples >= pixels else 0
    history = np.minimum(np.floor(history_count), FRESH_CAP * budget).astype(np.int64).reshape(shape)
    base = np.full(shape, floor, np.int64)
    return (base + even_fill(history + base, samples - floor * pixels, seed)).ravel()
