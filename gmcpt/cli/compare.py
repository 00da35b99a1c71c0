"""``gmcpt compare``: does the default pay off on your scene? The evaluation's equal-time comparison on one scene.

    gmcpt compare SCENE.xml [--reference REF.exr] [--budgets 2 4 8] [--res W H] [--out DIR] [--seed N]
    gmcpt compare SCENE.xml --frames A:B [--budgets 1 2 4] [--res W H] [--out DIR]
    gmcpt compare FRAME0.xml FRAME1.xml ... [--budgets 1 2 4] [--res W H] [--out DIR]

The scene's own integrator (the nested one, for a scene that names ``masked_path``) traces every contender:
the default (``gan_oidn`` through the budget chooser) at each budget, path tracing + OIDN and adaptive path
tracing + OIDN at each budget and at twice the largest, each timed warm by the evaluation's own
:func:`gmcpt.evaluation.measure.equal_time`. Without ``--reference`` a reference is rendered at
``--reference-spp`` (1024) and cached as the evaluation's are. Writes, under ``--out``: ``compare.json`` (every
figure, the settings, versions and timings, the budget chooser's way at each budget, the verdict's noise),
``psnr_vs_time.png`` and ``images.png`` (reference, the default, path tracing + OIDN at the nearest time, with FLIP
maps); prints the table and the verdict on stdout. *The run's noise*: a paired bootstrap over the default's budgets
and the timing rounds (:func:`gmcpt.evaluation.compare_report.verdict_noise`); where 90% of the draws hold 1 the
verdict says "a wash (within the run's noise)", and where the default went dense at every budget it says so first
(it traced every pixel: path tracing + OIDN with its own guides).

**An animation** (``--frames A:B``, a scene that reads ``$frame``: :func:`gmcpt.render.scene.check_animated`; or
an animation's scene files, one a frame, in the order given): the
default for animations, the sequence mode (:class:`gmcpt.temporal.sequence.SequenceRenderer`, its default history) at
each budget, against per-frame path tracing + OIDN at powers of two up to past 7.6x the largest budget
(:func:`gmcpt.evaluation.sequences.frame_ladder`), as ``benchmarks/sequence.py`` measures them
(:mod:`gmcpt.evaluation.sequences`):

- *Charged to each frame*: per-frame path tracing + OIDN pays Mitsuba's render of every pixel, one pass of
  Mitsuba's ``aov`` integrator for OIDN's guides and OIDN; the sequence mode pays all of
  ``SequenceRenderer.render`` (its survey, the traced samples, the gather of its history, OIDN). The contenders
  take turns frame by frame, so a machine whose pace drifts slows them alike.
- *Not charged*: loading the scene and setting its frame. What each frame changes (its elements that read
  ``$frame``, or that differ from the file before's) is loaded alone and set on one scene through ``mi.traverse``,
  made opaque (:class:`gmcpt.evaluation.sequences.XmlFrames`, every frame once up front to check it can be), as the
  benchmark moves its scenes. A scene loaded anew each
  frame would compile every kernel again each frame (its camera is a literal in them), a second and more on two
  cores, on both sides alike; a user's ``mi.render`` loop that moves the scene through ``mi.traverse`` with
  ``dr.make_opaque`` pays it once. Then every run renders the first three frames once, untimed and thrown away (a
  warm-up: every kernel compiled, including those a mesh that keeps moving runs plain after its second move,
  :data:`gmcpt.render.kernels.ANIMATED_MOVES`), and the timed run starts afresh. Every
  frame counts, the first ones too, where the sequence has little history yet: that is the animation's cost.
- *References*: each frame at ``--reference-spp`` (256), as two independent halves (PSNR against their mean,
  flicker against both so that their noise is no floor), cached as the single-frame reference is.
- *The run's noise*: a paired bootstrap over the frames (:func:`gmcpt.evaluation.sequences.verdict_noise`): the
  speed-up and flicker ratio re-read from resampled frames, the same frames for every contender; where 90% of
  the draws hold 1 the verdict says "a wash (within the run's noise)".

Writes, under ``--out``: ``compare.json`` (the rows with each frame's PSNR, seconds and flicker, the verdict, its
noise, settings, versions), ``psnr_vs_time.png`` (PSNR against seconds a frame) and ``compare.mp4`` (reference |
the sequence mode at the middle budget | per-frame path tracing + OIDN at the nearest time, side by side); prints
the sequence table and the verdict.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ..errors import GmcptError
from ..evaluation.compare_report import DEFAULT_BUDGETS, MAX_BUDGET, MIN_BUDGET, REFERENCE_SPP
from ..seeds import COMPARE_FRAME_STEP, SEQUENCE_REFERENCE_SEEDS
from .command import Parser, mitsuba_command, stamped_say

JSON, PLOT, IMAGES, MOVIE = "compare.json", "psnr_vs_time.png", "images.png", "compare.mp4"
#: ``--frames``: the sequence mode's budgets (the sequence benchmark's), and the samples of each frame's reference
#: (a reference for every frame: fewer than a single frame's)
FRAME_BUDGETS = (1.0, 2.0, 4.0)
FRAME_REFERENCE_SPP = 256
#: the pixels between the movie's pictures
MOVIE_GAP = 2


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("compare", "Does the default pay off on this scene? It against path tracing + OIDN and adaptive "
                    "path tracing + OIDN,\nat equal samples and at equal warm time, measured as `gmcpt eval` does. "
                    "With --frames, on the scene's $frame animation:\nthe sequence mode against per-frame path tracing "
                    "+ OIDN at equal time, with a side-by-side movie.")
    parser.add_argument("scenes", nargs="+", metavar="scene",
                        help="Mitsuba 3 scene XML (any integrator; masked_path's nested one is used); several: an "
                        "animation written one file a frame, in the order given, compared as --frames is")
    parser.add_argument("--reference", metavar="REF.exr",
                        help="reference EXR at the film size (default: render one at --reference-spp, cached)")
    parser.add_argument("--reference-spp", type=int, metavar="N",
                        help=f"samples a pixel of the reference it renders (default: {REFERENCE_SPP}; with --frames "
                        f"{FRAME_REFERENCE_SPP} a frame, as two independent halves)")
    parser.add_argument("--budgets", type=float, nargs="+", metavar="B",
                        help=f"samples a pixel of gan_oidn, or with --frames of the sequence mode, each in "
                        f"[{MIN_BUDGET:g}, {MAX_BUDGET:g}] (default: {' '.join(f'{b:g}' for b in DEFAULT_BUDGETS)}; "
                        f"with --frames {' '.join(f'{b:g}' for b in FRAME_BUDGETS)})")
    parser.add_argument("--frames", metavar="START:STOP",
                        help="an animation: the scene's $frame = START..STOP-1 (at least 2 frames), the sequence mode "
                        "against per-frame path tracing + OIDN at equal time; no --reference (default: one frame)")
    parser.add_argument("--res", type=int, nargs=2, metavar=("W", "H"), help="film resolution (default: the scene's)")
    parser.add_argument("--out", metavar="DIR",
                        help="folder of compare.json, psnr_vs_time.png, images.png, or with --frames compare.mp4 "
                        "instead of images.png (default: compare-SCENE)")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="first seed of the contenders' runs")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def scene_name(scene: str) -> str:
    """A scene's name in the outputs: its file's stem, or its folder's name for the usual ``NAME/scene.xml``."""
    path = Path(scene)
    return path.resolve().parent.name if path.stem == "scene" else path.stem


def _validate(args) -> Path:
    """Every check on the command line before any work; returns the output folder."""
    from ..io.files import check_output
    from ..limits import check_resolution, check_seed, check_spp

    for scene in args.scenes:
        if Path(scene).is_dir():
            raise GmcptError(f"{scene} is a folder: give the scene XML in it")
        if not Path(scene).is_file():
            raise GmcptError(f"scene file not found: {scene}")
    args.scene, args.files = args.scenes[0], (args.scenes if len(args.scenes) > 1 else None)
    if args.files and args.frames is not None:
        raise GmcptError("--frames animates one scene file; several files are an animation already (one a frame): "
                         "not both")
    animated = args.frames is not None or args.files
    if animated:
        _validate_frames(args)
    if args.budgets is None:
        args.budgets = list(FRAME_BUDGETS if animated else DEFAULT_BUDGETS)
    if args.reference_spp is None:
        args.reference_spp = FRAME_REFERENCE_SPP if animated else REFERENCE_SPP
    for budget in args.budgets:
        if not MIN_BUDGET <= budget <= MAX_BUDGET:  # NaN fails both
            raise GmcptError(f"--budgets must each be in [{MIN_BUDGET:g}, {MAX_BUDGET:g}] samples a pixel (the "
                             f"baselines trace at least 1 and at most {2 * MAX_BUDGET:g}), got {budget:g}")
    check_seed(args.seed, "--seed")
    check_spp(args.reference_spp, "--reference-spp")
    if args.res is not None:
        check_resolution(*args.res, 1, "--res")
    if args.reference and not Path(args.reference).is_file():
        raise GmcptError(f"reference not found: {args.reference}")
    out = Path(args.out or f"compare-{scene_name(args.scene)}")
    if out.exists() and not out.is_dir():
        raise GmcptError(f"--out {out} is not a folder")
    for name in (JSON, PLOT, MOVIE if animated else IMAGES):
        check_output(out / name)  # its folder is made when writing, if its parent exists
    return out


def frame_range(frames: str) -> range:
    """``START:STOP`` of ``--frames`` as the frames' range (one line if it is not, as ``gmcpt batch`` says it)."""
    from .batch import sweep_points

    points = sweep_points([], frames)
    return range(int(points[0][0][1]), int(points[-1][0][1]) + 1)


def _validate_frames(args) -> None:
    """``--frames`` (or several files): an animated scene, two frames or more, and no option it cannot take."""
    from ..render.scene import check_animated

    if args.reference:
        raise GmcptError("an animation renders a reference of each frame: drop --reference")
    if args.files:
        return
    if len(frame_range(args.frames)) < 2:
        raise GmcptError(f"--frames {args.frames} is one frame: an animation needs two or more (flicker is "
                         f"read between frames); without --frames compare takes one frame")
    check_animated(args.scene)


def _reference(args, size: tuple[int, int], say) -> tuple:
    """(reference, where it came from): ``--reference`` checked for size, or rendered and cached."""
    from ..runtime.progress import Progress
    from .render import read_reference
    from ..evaluation.reference import cache_dir, render_reference

    if args.reference:
        image = read_reference(args.reference)
        if image.shape[:2] != size[::-1]:
            raise GmcptError(f"reference {args.reference} is {image.shape[1]}x{image.shape[0]}, the film is "
                             f"{size[0]}x{size[1]} (--res W H, or gmcpt reference --res)")
        return image, str(Path(args.reference).resolve())
    passes = max(1, args.reference_spp // 256)
    with Progress(passes, "reference", unit="pass", say=say, quiet=args.quiet) as bar:
        started = []

        def on_pass(message: str) -> None:  # each pass is announced as it starts: the one before it is done
            if started:
                bar.update()
            started.append(message)
        image = render_reference(args.scene, size, args.reference_spp, progress=on_pass)
        if started:
            bar.update()
    say(f"reference: {args.reference_spp} spp at {size[0]}x{size[1]}, "
        + ("rendered and cached" if started else "from the cache") + f" in {cache_dir()}")
    return image, f"{args.reference_spp} spp, cached in {cache_dir()}"


class _Eta:
    """A ``say`` for :func:`measure.equal_time`: each line it says ends a setting, in the last of ``rounds`` rounds
    over all of them; the time left is the time so far scaled by the samples still to trace
    (:func:`compare_report.setting_weight`)."""

    def __init__(self, weights: list[float], say, rounds: int):
        self.weights, self.say, self.rounds, self.done, self.start = weights, say, rounds, 0, time.perf_counter()

    def __call__(self, message: str) -> None:
        from ..runtime.progress import format_seconds

        self.done = min(self.done + 1, len(self.weights))
        # the rounds before the last ran every setting once each
        spent = (self.rounds - 1) * sum(self.weights) + sum(self.weights[:self.done])
        left = sum(self.weights[self.done:])
        elapsed = time.perf_counter() - self.start
        self.say(f"{message.strip()}  [{self.done}/{len(self.weights)} settings, "
                 f"{format_seconds(elapsed * left / spent)} left]")


def _images(loaded, images: dict, rows: list[dict], config) -> dict:
    """Reference, the default at its middle budget, path tracing + OIDN at the time nearest the default's."""
    from ..evaluation.compare_report import nearest_in_time
    from ..evaluation.config import DEFAULT_VARIANT

    budget = config.default_budgets[len(config.default_budgets) // 2]
    mine = next(r for r in rows if r["contender"] == DEFAULT_VARIANT and r["rate"] * r["spp"] == budget)
    theirs = nearest_in_time(rows, "path+oidn", mine["seconds"])
    return {"reference": loaded.reference,
            f"{DEFAULT_VARIANT}, budget {budget:g} ({mine['seconds']:.2f} s)": images[(DEFAULT_VARIANT, budget)],
            f"path {theirs['spp']} spp + OIDN ({theirs['seconds']:.2f} s)": images[("path+oidn", float(theirs["spp"]))]}


def compare(args, say) -> dict:
    """Measure, write the outputs, print the table; returns the record written to ``compare.json``."""
    from ..io.exr import atomic_output
    from ..io.files import json_text, make_folder
    from ..render.scene import load_scene, path_integrator, scene_sensor
    from ..evaluation import compare_report, measure, plots
    from .eval import run_versions

    start = time.perf_counter()
    out = _validate(args)
    if args.frames is not None or args.files:
        return compare_frames(args, say, out, start)
    scene = load_scene(args.scene, tuple(args.res) if args.res else None)
    size = tuple(int(side) for side in scene_sensor(scene, path=args.scene).film().crop_size())
    reference, source = _reference(args, size, say)
    config = compare_report.compare_config(args.budgets, args.seed)
    loaded = measure.LoadedScene(scene_name(args.scene), scene, path_integrator(scene), reference)
    weights = [compare_report.setting_weight(s) * 3 for s in (*config.path_spp, *config.adaptive_budgets)]
    weights += [compare_report.setting_weight(b) * 2 for b in config.default_budgets]
    say(f"{args.scene}: {size[0]}x{size[1]}, {len(weights)} settings, each timed warm "
        f"{measure.timed_runs(config.repeats)} times after a warm-up")
    images = {}
    measured = time.perf_counter()
    rows = measure.equal_time(loaded, config, _Eta(weights, say, measure.all_rounds(config.repeats)), images)
    budgets = compare_report.per_budget(rows)
    found, noise, line = compare_report.verdict(rows)
    record = {"command": "gmcpt compare " + " ".join(args.argv),
              "scene": str(Path(args.scene).resolve()), "size": list(size), "reference": source,
              "reference_spp": None if args.reference else args.reference_spp, "config": asdict(config),
              "rows": rows, "budgets": budgets, "choices": compare_report.choices(rows), "verdict": found,
              "noise": noise, "verdict_line": line,
              "equal_samples_line": compare_report.equal_samples_line(budgets),
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "versions": run_versions(),
              "machine": f"{platform.machine()}, {os.cpu_count()} CPU cores, {platform.system()}",
              "measure_seconds": time.perf_counter() - measured}
    make_folder(out / JSON)
    plots.psnr_vs_time(rows, out / PLOT)
    plots.image_grid(_images(loaded, images, rows, config), out / IMAGES, f"{loaded.name}, {size[0]}x{size[1]}")
    record["seconds"] = time.perf_counter() - start
    with atomic_output(out / JSON) as temporary:
        Path(temporary).write_text(json_text(record) + "\n")
    print(compare_report.table(budgets))
    print(record["equal_samples_line"])
    print(line)
    say(f"wrote {out / JSON}, {out / PLOT}, {out / IMAGES} in {record['seconds']:.0f} s")
    return record


def _frame_truth(args, animation, frames: range, size: tuple[int, int], say):
    """Each frame's two references (cached: :func:`gmcpt.evaluation.reference.cached_reference`, keyed by the scene
    file, the frame, size, samples and seed) and geometry, as a :class:`~gmcpt.evaluation.sequences.Truth`."""
    from ..runtime.progress import Progress
    from ..temporal.survey import geometry
    from ..evaluation.reference import cache_dir, cached_reference, reference_key
    from ..evaluation.sequences import Truth
    from ..evaluation.stability import FrameGeometry

    half, figures = max(1, args.reference_spp // 2), ([], [], [])
    with Progress(len(frames), "references", unit="frame", say=say, quiet=args.quiet) as bar:
        for frame in frames:
            animation.at(frame)
            for found, first_seed in zip(figures, SEQUENCE_REFERENCE_SEEDS):
                seed = first_seed + COMPARE_FRAME_STEP * frame  # each pass of a reference takes the next seed
                key = reference_key(args.files[frame], size, half, seed, {}) if args.files else \
                    reference_key(args.scene, size, half, seed, {"frame": str(frame)})
                found.append(cached_reference(key, lambda: animation.scene, half, seed, label=scene_name(args.scene)))
            figures[2].append(FrameGeometry(*geometry(animation.scene, animation.scene.sensors()[0])))
            bar.update()
    say(f"references: {len(frames)} frames, 2 x {half} spp each, cached in {cache_dir()}")
    return Truth.of(*figures)


def _movie(runs: list, rows: list[dict], truth, path: Path) -> list[str]:
    """``compare.mp4``: each frame's reference, the sequence mode at its middle budget and per-frame path tracing
    + OIDN at the time nearest the sequence's, side by side; returns what each picture shows."""
    from ..io.video import write_video
    from ..evaluation.compare_report import nearest_in_time

    budgets = sorted(row["spp"] for row in rows if row["contender"] == "sequence")
    mine = next(row for row in rows if row["contender"] == "sequence" and row["spp"] == budgets[len(budgets) // 2])
    theirs = nearest_in_time(rows, "path+oidn", mine["seconds"])
    shown = [next(run for run in runs if (run.contender, run.amount) == (row["contender"], row["spp"]))
             for row in (mine, theirs)]
    shape = truth.firsts[0].shape
    gap = np.zeros((shape[0], MOVIE_GAP, 3), np.float32)
    write_video((np.concatenate([reference, gap, np.reshape(a, shape), gap, np.reshape(b, shape)], axis=1)
                 for reference, a, b in zip(truth.references, shown[0].images, shown[1].images)), path)
    return ["reference", f"sequence mode, budget {mine['spp']:g} ({mine['seconds']:.3f} s a frame)",
            f"path {theirs['spp']:g} spp + OIDN ({theirs['seconds']:.3f} s a frame)"]


def compare_frames(args, say, out: Path, start: float) -> dict:
    """``--frames``: the sequence mode against per-frame path tracing + OIDN over the scene's animation (the
    module's docstring: what each is charged, the references, the noise); writes the outputs, prints the table and
    the verdict; returns the record written to ``compare.json``."""
    import mitsuba as mi

    from ..io.exr import atomic_output
    from ..io.files import json_text, make_folder
    from ..runtime.progress import Progress
    from ..render.kernels import ANIMATED_MOVES
    from ..render.scene import path_integrator
    from ..evaluation import plots
    from .eval import run_versions, machine_line
    from ..evaluation.sequences import (AOV_GUIDES, XmlFrames, frame_figures, frame_ladder, frames_table,
                                        frames_verdict_line, path_oidn_run, sequence_figures, sequence_run,
                                        sequence_verdict, take_turns, verdict_noise)

    frames = range(len(args.files)) if args.files else frame_range(args.frames)
    say(f"{args.scene}: loading frames {frames.start}-{frames.stop - 1}" + (" (a file each)" if args.files else ""))
    animation = XmlFrames(args.scene, tuple(args.res) if args.res else None, frames, args.files)
    scene = animation.scene
    size = tuple(int(side) for side in scene.sensors()[0].film().crop_size())
    truth = _frame_truth(args, animation, frames, size, say)
    integrator, aov = path_integrator(scene), mi.load_dict(AOV_GUIDES)
    budgets, ladder = sorted(set(args.budgets)), frame_ladder(args.budgets)

    def runs() -> list:
        return [path_oidn_run(scene, integrator, aov, spp) for spp in ladder] \
            + [sequence_run(scene, integrator, budget, args.seed) for budget in budgets]

    def seed(frame: int) -> int:
        return args.seed + frame - frames.start

    # a mesh that moved twice has the kernels run plain: with a warm-up of two frames those compiled in the timed run
    # (1.1 s of one frame of a moving sofa at 256x256, docs/experiments.md)
    warm = ANIMATED_MOVES + 1

    say(f"{size[0]}x{size[1]}, {len(frames)} frames: the sequence mode at budget "
        f"{', '.join(f'{b:g}' for b in budgets)}, path tracing + OIDN at {', '.join(map(str, ladder))} spp, after a "
        f"warm-up on the first {min(len(frames), warm)} frames")
    take_turns(runs(), frames[:warm], animation.at, seed)
    measured, timed = runs(), time.perf_counter()
    with Progress(len(frames), "frames", unit="frame", say=say, quiet=args.quiet) as bar:
        for frame in frames:
            take_turns(measured, [frame], animation.at, seed)
            bar.update()
    name, motion = scene_name(args.scene), f"frames {frames.start}-{frames.stop - 1}"
    rows = [{"scene": name, "motion": motion, "contender": run.contender, "rate": 1.0, "spp": run.amount,
             **sequence_figures(run.images, run.seconds, truth),
             "frames": frame_figures(run.images, run.seconds, truth)} for run in measured]
    verdict = sequence_verdict(rows, "path+oidn")
    noise = verdict_noise(rows, seed=args.seed) if verdict else {}
    line = frames_verdict_line(verdict, noise)
    record = {"command": "gmcpt compare " + " ".join(args.argv), "scene": str(Path(args.scene).resolve()),
              "files": [str(Path(file).resolve()) for file in args.files] if args.files else None,
              "size": list(size), "frames": [frames.start, frames.stop], "reference_spp": args.reference_spp,
              "budgets": budgets, "path_spp": list(ladder), "seed": args.seed, "rows": rows, "verdict": verdict,
              "noise": noise, "verdict_line": line,
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "versions": run_versions(), "machine": machine_line(), "measure_seconds": time.perf_counter() - timed}
    make_folder(out / JSON)
    plots.sequence_plot(rows, out / PLOT)
    record["movie"] = _movie(measured, rows, truth, out / MOVIE)
    record["seconds"] = time.perf_counter() - start
    with atomic_output(out / JSON) as temporary:
        Path(temporary).write_text(json_text(record) + "\n")
    print(frames_table(rows))
    print(line)
    say(f"wrote {out / JSON}, {out / PLOT}, {out / MOVIE} ({' | '.join(record['movie'])}) in {record['seconds']:.0f} s")
    return record


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt compare``; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)

    def work(args) -> int:
        args.argv = argv  # recorded in compare.json
        compare(args, stamped_say("compare", args.quiet))
        return 0
    return mitsuba_command(argv, build_parser, work)


if __name__ == "__main__":
    sys.exit(main())
