"""The sequence mode against per-frame path tracing + OIDN, shared by ``benchmarks/sequence.py`` (evaluation scenes
moved through ``mi.traverse``) and ``gmcpt compare SCENE --frames A:B`` (a scene file's own ``$frame`` animation):
how the baseline renders a frame (:func:`path_oidn`), how the contenders take turns (:func:`take_turns`), how a
scene file's frames become one scene whose parameters change (:class:`XmlFrames`), and the figures of a run
(:func:`sequence_figures`, :func:`sequence_verdict`).

The rest are the figures of the benchmark's record (``benchmarks/sequence.py --record``) as pure functions of its
rows: what the benchmark prints, the plot draws and ``docs/results.md`` states all come from here, so that they agree.

A row is one contender at one setting on one (scene, motion): ``contender`` (``path+oidn``, ``accumulation+oidn``,
``sequence``), ``spp`` (samples a pixel a frame), ``seconds`` (warm, a frame), ``psnr`` and the other figures.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

#: The motions in which the camera moves; in the others (``object``, ``light``) the scene changes under a still
#: camera, where history goes stale without any reprojection to tell.
CAMERA_MOTIONS = ("pan", "dolly")
#: What moves in each motion of the benchmark, in words (its record says what moved in each scene).
MOTION_WORDS = {"pan": "The camera turns about its own up axis", "dolly": "The camera moves along its view",
                "object": "The camera stays; an object slides across the room, its shadow with it",
                "light": "The camera stays; the scene's main light turns about the vertical through the scene's "
                         "centre, as the sun does, its patches and shadows with it",
                "still": "Nothing moves: every past sample lands where it was traced and none goes stale, what reusing "
                         "them gives at this cost a frame, the ceiling of the motions above"}
#: The plot's ceiling, as issue 75 sets it: path tracing + OIDN at this many times the sequence's samples a pixel a
#: frame, the quality that reusing earlier frames' samples is held against.
CEILING_SAMPLES = 7.6


def frame_ladder(budgets) -> tuple[int, ...]:
    """Per-frame path tracing's samples a pixel against the sequence mode at ``budgets``: powers of two up to the
    first at or past :data:`CEILING_SAMPLES` x the largest budget, the quality the sequence is held against (so
    that the time the baseline needs for the sequence's PSNR is read between its settings, not bounded), and each
    budget rounded (equal samples)."""
    top = int(np.ceil(np.log2(CEILING_SAMPLES * max(budgets))))
    return tuple(sorted({2 ** k for k in range(top + 1)} | {max(1, round(b)) for b in budgets}))


def frames_table(rows: list[dict]) -> str:
    """The sequence table of ``gmcpt compare --frames``: each contender's setting, PSNR, PSNR over the changed
    pixels (and their share), seconds a frame and flicker (along the motion; in place)."""
    from .report import markdown_table

    lines = [[row["contender"], f"{row['spp']:g}", f"{row['psnr']:.2f}",
              "-" if row["psnr_changed"] is None else f"{row['psnr_changed']:.2f} ({row['changed_share']:.1%})",
              f"{row['seconds']:.3f}", f"{row['flicker']:.2f} ({row['screen_flicker']:.2f})"] for row in rows]
    return markdown_table(["contender", "samples a pixel a frame", "PSNR dB", "PSNR changed pixels dB (share)",
                   "seconds a frame", "flicker (in place)"], lines)


def motion_of(row: dict, settings: dict) -> str:
    """A row's motion; records from before the benchmark ran several motions had one, in their settings."""
    ran = settings.get("motion", "pan")
    return row.get("motion") or (ran if isinstance(ran, str) else ran[0])


def motions(sequences: dict) -> list[str]:
    """The motions of a record, in the order the benchmark ran them (its ``--motion``), then any other its rows or
    verdicts have."""
    settings = sequences["settings"]
    ran = settings.get("motion", "pan")
    found = [motion_of(item, settings) for item in sequences["rows"] + sequences["verdicts"]]
    return list(dict.fromkeys(([ran] if isinstance(ran, str) else list(ran)) + found))


def groups(rows: list[dict], settings: dict | None = None) -> list[tuple[str, str]]:
    """The (scene, motion) pairs of ``rows``, in their order."""
    return list(dict.fromkeys((r["scene"], motion_of(r, settings or {})) for r in rows))


def at_equal_time(rows: list[dict], baseline: str, figure: str) -> list[tuple[float, float]]:
    """For each sequence row with ``figure``: (its figure, ``baseline``'s at the same seconds a frame), the
    baseline's interpolated in log time between its settings and held at its ends. Rows of one (scene, motion)."""
    points = sorted((r["seconds"], r[figure]) for r in rows if r["contender"] == baseline and r.get(figure) is not None)
    if not points:
        return []
    times, values = np.log([p[0] for p in points]), [p[1] for p in points]
    return [(r[figure], float(np.interp(np.log(r["seconds"]), times, values)))
            for r in rows if r["contender"] == "sequence" and r.get(figure) is not None]


def equal_time_ratio(rows: list[dict], baseline: str, figure: str = "flicker") -> float | None:
    """Geometric mean over the sequence's settings of its ``figure`` over ``baseline``'s at the same seconds a
    frame (:func:`at_equal_time`): below 1 the sequence flickers less. None where either has no figure."""
    pairs = at_equal_time(rows, baseline, figure)
    return float(np.exp(np.mean([np.log(mine / theirs) for mine, theirs in pairs]))) if pairs else None


def equal_time_gap(rows: list[dict], baseline: str, figure: str = "psnr_changed") -> float | None:
    """Mean over the sequence's settings of its ``figure`` (dB) minus ``baseline``'s at the same seconds a frame
    (:func:`at_equal_time`): negative where the sequence is behind. None where either has no figure."""
    pairs = at_equal_time(rows, baseline, figure)
    return float(np.mean([mine - theirs for mine, theirs in pairs])) if pairs else None


def ceiling(rows: list[dict], factor: float = CEILING_SAMPLES) -> list[tuple[float, float]]:
    """(seconds a frame, PSNR) for each sequence row: the PSNR path tracing + OIDN reaches at ``factor`` x the
    sequence's samples a pixel (interpolated in log samples between its settings, held at its ends), drawn at the
    sequence's seconds. Rows of one (scene, motion); empty without both."""
    points = sorted((r["spp"], r["psnr"]) for r in rows if r["contender"] == "path+oidn")
    if not points:
        return []
    samples, values = np.log([p[0] for p in points]), [p[1] for p in points]
    return sorted((r["seconds"], float(np.interp(np.log(factor * r["spp"]), samples, values)))
                  for r in rows if r["contender"] == "sequence")


def _span(values: list[float], form: str) -> str:
    """``1.2-1.9x`` of ``values`` (one value alone)."""
    low, high = min(values), max(values)
    return f"{low:{form}}x" if f"{low:{form}}" == f"{high:{form}}" else f"{low:{form}}-{high:{form}}x"


def glance_line(sequences: dict) -> str:
    """One line on the sequence mode's verdicts from the benchmark's record: its speed-up at equal quality over
    per-frame path tracing + OIDN (the yardstick) on camera motion, on moving objects and lights and with nothing
    moving, its flicker over that baseline's at equal time where something moves, and its speed-up over
    accumulation + OIDN."""
    settings, verdicts = sequences["settings"], sequences["verdicts"]

    def spans(baseline: str) -> list[str]:
        said = []
        for label, chosen in (("on pans and dollies", lambda motion: motion in CAMERA_MOTIONS),
                              ("on moving objects and lights", lambda motion: motion in ("object", "light")),
                              ("with nothing moving", lambda motion: motion == "still")):
            speedups = [v["speedup"] for v in verdicts
                        if v["baseline"] == baseline and chosen(motion_of(v, settings))]
            if speedups:
                said.append(f"{_span(speedups, '.2f')} {label}")
        return said

    flicker = [v["flicker_ratio"] for v in verdicts if v["baseline"] == "path+oidn"
               and v.get("flicker_ratio") is not None and motion_of(v, settings) != "still"]
    accumulation, light_paths = spans("accumulation+oidn"), spans("lightpath+oidn")
    return (f"**Sequences** (`benchmarks/sequence.py`, {len({v['scene'] for v in verdicts})} scenes at "
            f"{settings['res']}x{settings['res']}): the sequence mode's speed-up at equal quality over per-frame path "
            f"tracing + OIDN is {'; '.join(spans('path+oidn')) or 'not measured'} (above 1x it is faster)"
            + (f", its flicker {_span(flicker, '.2f')} of that baseline's at equal time" if flicker else "")
            + (f"; over per-frame path tracing + OIDN with the sequence's light samples (its estimator alone) "
               f"{'; '.join(light_paths)}" if light_paths else "")
            + (f"; over accumulation + OIDN {'; '.join(accumulation)}" if accumulation else "")
            + " (*Sequences* below).")


#: Mitsuba's ``aov`` integrator for OIDN's guides, as a Mitsuba user would render them.
AOV_GUIDES = {"type": "aov", "aovs": "a:albedo,n:sh_normal"}


def denoised_with_aov_guides(scene, aov, noisy: np.ndarray, spp: int, seed: int) -> np.ndarray:
    """``noisy`` (N, 3) through OIDN with the guides of one pass of Mitsuba's ``aov`` integrator at ``spp``
    (:func:`aov_guides`, :func:`denoised_with`)."""
    return denoised_with(noisy, aov_guides(scene, aov, spp, seed), spp)


def aov_guides(scene, aov, spp: int, seed: int) -> np.ndarray:
    """One pass of ``aov`` (:data:`AOV_GUIDES`) at ``spp``: (H, W, 6) albedo and shading normal."""
    import mitsuba as mi

    return np.asarray(mi.render(scene, integrator=aov, spp=spp, seed=seed), dtype=np.float32)


def denoised_with(noisy: np.ndarray, guides: np.ndarray, spp: int) -> np.ndarray:
    """``noisy`` (N, 3) through OIDN with :func:`aov_guides`' ``guides``: the albedo clipped to [0, 1] (OIDN's range;
    Mitsuba's albedo of a rough metal reaches 18 in the dining room) and the shading normal in world space, a pixel's
    mean of unit normals (0 on a miss), as OIDN takes them and as :func:`gmcpt.render.kernels.render_features` gives
    them but for the renormalising, which OIDN does not need."""
    from ..image.denoise import denoise_oidn

    return denoise_oidn(noisy.reshape(*guides.shape[:2], 3), np.clip(guides[..., 0:3], 0, 1), guides[..., 3:6], spp)


def path_oidn(scene, integrator, aov, spp: int, seed: int) -> tuple[np.ndarray, dict]:
    """A frame on its own, as a Mitsuba user denoises it: Mitsuba's render of every pixel at ``spp``
    (:func:`gmcpt.render.kernels.render_native`), one pass of ``aov`` at as many samples for OIDN's guides
    (:func:`aov_guides`), then OIDN (:func:`denoised_with`). All three are what :func:`take_turns` charges it: (the
    image, each stage's seconds: ``render_s``, ``guides_s``, ``denoise_s``)."""
    from ..render.kernels import render_native

    started = time.perf_counter()
    noisy = render_native(scene, scene.sensors()[0], integrator, spp, seed)
    rendered = time.perf_counter()
    guides = aov_guides(scene, aov, spp, seed)
    guided = time.perf_counter()
    image = denoised_with(noisy, guides, spp)
    return image, {"render_s": rendered - started, "guides_s": guided - rendered,
                   "denoise_s": time.perf_counter() - guided}


@dataclass
class Run:
    """One contender at one setting through a sequence: ``render(frame, seed)`` gives a frame's image and its stages'
    seconds (a dict, empty where it has none), and all it does is charged to it; the images, seconds and stages of
    the frames so far."""

    contender: str
    amount: float  # samples a pixel a frame: spp, or the sequence's budget
    render: Callable[[int, int], tuple[np.ndarray, dict]]
    images: list = field(default_factory=list)
    seconds: list = field(default_factory=list)
    stages: list = field(default_factory=list)


def path_oidn_run(scene, integrator, aov, spp: int) -> Run:
    """Per-frame path tracing + OIDN at ``spp`` (:func:`path_oidn`) on ``scene`` as it is at each frame."""
    return Run("path+oidn", spp, lambda frame, seed: path_oidn(scene, integrator, aov, spp, seed))


def light_path_oidn_run(scene, integrator, aov, spp: int) -> Run:
    """Per-frame path tracing + OIDN at ``spp`` as :func:`path_oidn_run`, its paths taking the sequence mode's emitter
    samples at their first hit (:data:`gmcpt.temporal.sequence.LIGHT_SAMPLES`): what that estimator alone buys, so
    that the sequence's own share of its speed-up shows."""
    from ..render.guided_path import twin_of
    from ..temporal.sequence import LIGHT_SAMPLES

    tracer = twin_of(scene, integrator, LIGHT_SAMPLES, features=False) or integrator
    return Run("lightpath+oidn", spp, lambda frame, seed: path_oidn(scene, tracer, aov, spp, seed))


def sequence_run(scene, integrator, budget: float, seed: int) -> Run:
    """The sequence mode (:class:`gmcpt.temporal.sequence.SequenceRenderer`, its default history) at ``budget``, seeded
    once for the sequence (each frame draws its own from it)."""
    from ..temporal.sequence import SequenceRenderer, SequenceSettings

    renderer = SequenceRenderer(SequenceSettings(budget=budget, seed=seed))

    def render(frame: int, _) -> tuple[np.ndarray, dict]:
        image, _, timings = renderer.render(scene, frame, integrator)
        return image, timings
    return Run("sequence", budget, render)


def take_turns(runs: list[Run], frames, at: Callable[[int], None], seed: Callable[[int], int]) -> None:
    """Frame by frame, every run in turn (a machine whose pace drifts over minutes slows them alike): ``at(frame)``
    sets the scene, uncharged; then each run renders the frame with ``seed(frame)``, timed."""
    for frame in frames:
        at(frame)
        for run in runs:
            start = time.perf_counter()
            image, stages = run.render(frame, seed(frame))
            run.seconds.append(time.perf_counter() - start)
            run.images.append(image)
            run.stages.append(stages)


def stage_means(stages: list[dict], seconds: list, warm: int) -> dict:
    """Each stage's mean seconds a frame over the frames after ``warm``, and ``other_s``: the frame's seconds that no
    stage holds (Python between the stages, the record). Empty where the run timed no stages."""
    kept = [(timings, total) for timings, total in zip(stages[warm:], seconds[warm:]) if timings]
    if not kept:
        return {}
    names = list(dict.fromkeys(name for timings, _ in kept for name in timings))
    means = {name: float(np.mean([timings.get(name, 0.0) for timings, _ in kept])) for name in names}
    return {**means, "other_s": max(0.0, float(np.mean([total for _, total in kept])) - sum(means.values()))}


class XmlFrames:
    """A scene file's ``$frame`` animation as one scene whose parameters change from frame to frame (:meth:`at`),
    as the benchmark's ``SceneMotion`` moves the evaluation's scenes: a :class:`~gmcpt.render.frames.SceneFrames`
    held for ``frames``, each of them set once up front (uncharged) to check that it can be. Rendering a newly
    loaded scene each frame would compile every kernel again each frame (its camera, a literal, is compiled into
    them: a second and more a frame on two cores), in each contender alike; one scene with opaque parameters
    compiles once. A frame whose change ``mi.traverse`` cannot set (a parameter that comes or goes, a mesh of
    another size, an integer) would be another scene: one line.
    """

    def __init__(self, path, resolution: tuple[int, int] | None, frames: range, files: list | None = None):
        from ..render.frames import SceneFrames

        self.files = files  # an animation written one file a frame: frame i is files[i]
        self.frames = SceneFrames(path, resolution)
        self.scene = self._at(frames[0])
        for frame in (*frames[1:], frames[0]):
            self.at(frame)

    def _at(self, frame: int):
        return self.frames.at({}, self.files[frame]) if self.files else self.frames.at({"frame": str(frame)})

    def at(self, frame: int) -> None:
        """Set the scene as it is at ``frame``."""
        from ..errors import GmcptError

        if self._at(frame) is not self.scene:
            raise GmcptError(f"frame {frame} ({self.files[frame] if self.files else self.frames.path}) is another "
                             f"scene, not values mi.traverse can set on one: {self.frames.whole_reason}")


@dataclass(frozen=True)
class Truth:
    """What a sequence's runs are read against: two independent references of each frame (``firsts``,
    ``seconds``; PSNR against their mean, flicker against both: :mod:`gmcpt.evaluation.stability`), each frame's
    geometry, the frames left out of the figures at the start (``warm``) and, per frame after them, its changed
    pixels (:func:`gmcpt.evaluation.stability.changed_pixels`)."""

    firsts: list
    seconds: list
    geometries: list
    warm: int
    changed: dict

    @classmethod
    def of(cls, firsts: list, seconds: list, geometries: list, warm: int = 0) -> "Truth":
        from .stability import changed_pixels

        changed = {t: changed_pixels(firsts, seconds, geometries, t) for t in range(max(1, warm), len(firsts))}
        return cls(firsts, seconds, geometries, warm, changed)

    @property
    def references(self) -> list:
        return [(a + b) / 2 for a, b in zip(self.firsts, self.seconds)]

    @property
    def changed_share(self) -> float:
        return float(np.mean([mask.mean() for mask in self.changed.values()])) if self.changed else 0.0


def sequence_figures(images: list, seconds: list, truth: Truth) -> dict:
    """A run's figures over the frames after ``truth.warm``: mean PSNR and FLIP, PSNR over the changed pixels
    (pooled) and their share, mean seconds a frame, flicker along the motion and in place."""
    from ..image.metrics import all_metrics
    from .stability import changed_psnr, screen_flicker, surface_flicker

    kept, references = slice(truth.warm, None), truth.references
    metrics = [all_metrics(i, r) for i, r in zip(images[kept], references[kept])]
    changed = list(truth.changed)
    return {"psnr": float(np.mean([m["psnr"] for m in metrics])),
            "psnr_changed": changed_psnr([images[t] for t in changed], [references[t] for t in changed],
                                         list(truth.changed.values())),
            "changed_share": truth.changed_share, "flip": float(np.mean([m["flip"] for m in metrics])),
            "seconds": float(np.mean(seconds[kept])),
            "flicker": surface_flicker(images[kept], truth.firsts[kept], truth.geometries[kept], truth.seconds[kept]),
            "screen_flicker": screen_flicker(images[kept], truth.firsts[kept], truth.seconds[kept])}


def sequence_verdict(rows: list[dict], baseline: str) -> dict | None:
    """The sequence mode against ``baseline`` on one (scene, motion): its equal-time speed-up
    (:func:`gmcpt.evaluation.report.equal_time_verdict`), its flicker over the baseline's at the same seconds a
    frame (along the motion and in place) and its ``psnr_changed`` minus the baseline's there. None where either
    did not run."""
    from .report import equal_time_verdict

    verdict = equal_time_verdict(rows, "sequence", (baseline,))
    if not verdict:
        return None
    return {"baseline": baseline, "speedup": verdict["speedup"], "bounds": verdict["bounds"],
            "settings": verdict["settings"], "flicker_ratio": equal_time_ratio(rows, baseline),
            "screen_flicker_ratio": equal_time_ratio(rows, baseline, "screen_flicker"),
            "changed_gap_db": equal_time_gap(rows, baseline)}


#: Resamples of the frames behind the noise of a sequence's verdict (:func:`verdict_noise`), and the share of them
#: its interval holds: the 5th to the 95th percentile.
NOISE_DRAWS = 1000
NOISE_LEVEL = 0.9


def frame_figures(images: list, seconds: list, truth: Truth) -> dict:
    """A run's figures frame by frame after ``truth.warm``, for :func:`verdict_noise`: PSNR and seconds of each
    frame, and the flicker (along the motion, against both references) of each pair of consecutive frames."""
    from ..image.metrics import psnr
    from .stability import surface_flicker

    kept, references = range(truth.warm, len(images)), truth.references
    return {"psnr": [psnr(images[t], references[t]) for t in kept], "seconds": [float(seconds[t]) for t in kept],
            "flicker": [surface_flicker(images[t - 1:t + 1], truth.firsts[t - 1:t + 1], truth.geometries[t - 1:t + 1],
                                        truth.seconds[t - 1:t + 1]) for t in kept if t > truth.warm]}


def _drawn(row: dict, frames: np.ndarray, pairs: np.ndarray) -> dict:
    """``row`` with its PSNR and seconds the means over ``frames``, its flicker the RMS over ``pairs`` (its
    ``frames`` figures: :func:`frame_figures`)."""
    figures = row["frames"]
    flicker = np.asarray(figures["flicker"], dtype=np.float64)
    return dict(row, psnr=float(np.mean(np.asarray(figures["psnr"])[frames])),
                seconds=float(np.mean(np.asarray(figures["seconds"])[frames])),
                flicker=float(np.sqrt(np.mean(flicker[pairs] ** 2))) if pairs.size else None)


def verdict_noise(rows: list[dict], baseline: str = "path+oidn", draws: int = NOISE_DRAWS,
                  level: float = NOISE_LEVEL, seed: int = 0) -> dict:
    """How far the run's noise moves :func:`sequence_verdict`'s speed-up and flicker ratio: a paired bootstrap over
    the frames. Each draw takes as many frames as the run had, with replacement, the same frames for every row
    (and as many pairs of frames for the flicker), and reads the verdict from their means; the interval holds
    ``level`` of the draws. So a frame that was slow for every contender (the machine) moves them together, and
    what moves the verdict is how the contenders' PSNR and seconds vary from frame to frame: the timing noise and
    the scene's own changes along the animation. Rows carry their ``frames`` figures (:func:`frame_figures`).

    Returns ``{"speedup": (low, high) or None, "flicker_ratio": (low, high) or None, "draws", "level"}``."""
    from .report import equal_time_verdict

    chosen = [r for r in rows if r["contender"] in ("sequence", baseline)]
    count, pairs = len(chosen[0]["frames"]["psnr"]), len(chosen[0]["frames"]["flicker"])
    random = np.random.default_rng(seed)
    found = {"speedup": [], "flicker_ratio": []}
    for _ in range(draws):
        frames, paired = random.integers(0, count, count), random.integers(0, max(pairs, 1), pairs)
        drawn = [_drawn(row, frames, paired) for row in chosen]
        verdict = equal_time_verdict(drawn, "sequence", (baseline,))
        if verdict:
            found["speedup"].append(verdict["speedup"])
        ratio = equal_time_ratio([r for r in drawn if r["flicker"]], baseline) if pairs else None
        if ratio is not None and np.isfinite(ratio):
            found["flicker_ratio"].append(ratio)
    tail = 100 * (1 - level) / 2
    return {**{key: (tuple(float(v) for v in np.percentile(values, [tail, 100 - tail])) if values else None)
               for key, values in found.items()}, "draws": draws, "level": level}


def within_noise(interval: tuple[float, float] | None) -> bool:
    return interval is not None and interval[0] <= 1 <= interval[1]


def frames_verdict_line(verdict: dict | None, noise: dict, baseline: str = "per-frame path tracing + OIDN") -> str:
    """One line: the sequence mode's speed-up at equal quality over ``baseline`` and its flicker over the
    baseline's at equal time, each with its interval (:func:`verdict_noise`), or "a wash (within the run's
    noise)" where the interval holds 1."""
    if verdict is None:
        return f"verdict: none: the sequence mode or {baseline} did not run"
    ratio, spread = verdict["speedup"], noise.get("speedup")
    if within_noise(spread):
        speed = (f"against {baseline} at equal quality: a wash (within the run's noise: a speed-up of {ratio:.2f}x, "
                 f"{spread[0]:.2f}-{spread[1]:.2f}x)")
    else:
        way, shown = ("faster", (ratio, spread)) if ratio >= 1 else \
            ("slower", (1 / ratio, spread and (1 / spread[1], 1 / spread[0])))
        speed = f"is {shown[0]:.2f}x {way} than {baseline} at equal quality" + (
            f" ({shown[1][0]:.2f}-{shown[1][1]:.2f}x within the run's noise)" if spread else "")
    if verdict["bounds"]:
        speed += (f" ({verdict['bounds']} of {verdict['settings']} ratios only bounds: the baseline's samples "
                  f"did not reach the sequence's PSNR)")
    flicker, spread = verdict.get("flicker_ratio"), noise.get("flicker_ratio")
    if flicker is None:
        said = "its flicker not measured"
    elif within_noise(spread):
        said = f"its flicker a wash (within the run's noise: {flicker:.2f}x, {spread[0]:.2f}-{spread[1]:.2f}x)"
    else:
        said = f"its flicker {flicker:.2f}x the baseline's at equal time" + (
            f" ({spread[0]:.2f}-{spread[1]:.2f}x)" if spread else "")
    return f"verdict: the sequence mode {speed}; {said}"
