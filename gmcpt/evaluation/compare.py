"""``gmcpt compare``: does the default pay off on your scene? The evaluation's equal-time comparison on one scene.

    gmcpt compare SCENE.xml [--reference REF.exr] [--budgets 2 4 8] [--res W H] [--out DIR] [--seed N]

The scene's own integrator (the nested one, for a scene that names ``masked_path``) traces every contender:
the default (``gan_oidn`` through the budget chooser) at each budget, path tracing + OIDN and adaptive path
tracing + OIDN at each budget and at twice the largest, each timed warm by the evaluation's own
:func:`gmcpt.evaluation.measure.equal_time`. Without ``--reference`` a reference is rendered at
``--reference-spp`` (1024) and cached as the evaluation's are. Writes, under ``--out``: ``compare.json`` (every
figure, the settings, versions and timings), ``psnr_vs_time.png`` and ``images.png`` (reference, the default,
path tracing + OIDN at the nearest time, with FLIP maps); prints the table and the verdict on stdout.
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

from ..command import Parser, mitsuba_command, stamped_say
from ..errors import GmcptError
from .compare_report import DEFAULT_BUDGETS, MAX_BUDGET, MIN_BUDGET, REFERENCE_SPP

JSON, PLOT, IMAGES = "compare.json", "psnr_vs_time.png", "images.png"


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("compare", "Does the default pay off on this scene? It against path tracing + OIDN and adaptive "
                    "path tracing + OIDN,\nat equal samples and at equal warm time, measured as `gmcpt eval` does.")
    parser.add_argument("scene", help="Mitsuba 3 scene XML (any integrator; masked_path's nested one is used)")
    parser.add_argument("--reference", metavar="REF.exr",
                        help="reference EXR at the film size (default: render one at --reference-spp, cached)")
    parser.add_argument("--reference-spp", type=int, default=REFERENCE_SPP, metavar="N",
                        help="samples a pixel of the reference it renders")
    parser.add_argument("--budgets", type=float, nargs="+", default=list(DEFAULT_BUDGETS), metavar="B",
                        help=f"samples a pixel of gan_oidn, each in [{MIN_BUDGET:g}, {MAX_BUDGET:g}] "
                        f"(default: {' '.join(f'{b:g}' for b in DEFAULT_BUDGETS)})")
    parser.add_argument("--res", type=int, nargs=2, metavar=("W", "H"), help="film resolution (default: the scene's)")
    parser.add_argument("--out", metavar="DIR",
                        help="folder of compare.json, psnr_vs_time.png, images.png (default: compare-SCENE)")
    parser.add_argument("--seed", type=int, default=0, metavar="N", help="first seed of the contenders' runs")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def scene_name(scene: str) -> str:
    """A scene's name in the outputs: its file's stem, or its folder's name for the usual ``NAME/scene.xml``."""
    path = Path(scene)
    return path.resolve().parent.name if path.stem == "scene" else path.stem


def _validate(args) -> Path:
    """Every check on the command line before any work; returns the output folder."""
    from ..files import check_output
    from ..limits import check_resolution, check_seed, check_spp

    if Path(args.scene).is_dir():
        raise GmcptError(f"{args.scene} is a folder: give the scene XML in it")
    if not Path(args.scene).is_file():
        raise GmcptError(f"scene file not found: {args.scene}")
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
    for name in (JSON, PLOT, IMAGES):
        check_output(out / name)  # its folder is made when writing, if its parent exists
    return out


def _reference(args, size: tuple[int, int], say) -> tuple:
    """(reference, where it came from): ``--reference`` checked for size, or rendered and cached."""
    from ..progress import Progress
    from ..render_cli import _reference as read_reference
    from .reference import cache_dir, render_reference

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
        from ..progress import format_seconds

        self.done = min(self.done + 1, len(self.weights))
        # the rounds before the last ran every setting once each
        spent = (self.rounds - 1) * sum(self.weights) + sum(self.weights[:self.done])
        left = sum(self.weights[self.done:])
        elapsed = time.perf_counter() - self.start
        self.say(f"{message.strip()}  [{self.done}/{len(self.weights)} settings, "
                 f"{format_seconds(elapsed * left / spent)} left]")


def _images(loaded, images: dict, rows: list[dict], config) -> dict:
    """Reference, the default at its middle budget, path tracing + OIDN at the time nearest the default's."""
    from .compare_report import nearest_in_time
    from .config import DEFAULT_VARIANT

    budget = config.default_budgets[len(config.default_budgets) // 2]
    mine = next(r for r in rows if r["contender"] == DEFAULT_VARIANT and r["rate"] * r["spp"] == budget)
    theirs = nearest_in_time(rows, "path+oidn", mine["seconds"])
    return {"reference": loaded.reference,
            f"{DEFAULT_VARIANT}, budget {budget:g} ({mine['seconds']:.2f} s)": images[(DEFAULT_VARIANT, budget)],
            f"path {theirs['spp']} spp + OIDN ({theirs['seconds']:.2f} s)": images[("path+oidn", float(theirs["spp"]))]}


def compare(args, say) -> dict:
    """Measure, write the outputs, print the table; returns the record written to ``compare.json``."""
    from ..exr import atomic_output
    from ..files import json_text, make_folder
    from ..scene import load_scene, path_integrator, scene_sensor
    from . import compare_report, measure, plots
    from .cli import _versions

    start = time.perf_counter()
    out = _validate(args)
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
    found, line = compare_report.verdict(rows)
    record = {"command": "gmcpt compare " + " ".join(args.argv),
              "scene": str(Path(args.scene).resolve()), "size": list(size), "reference": source,
              "reference_spp": None if args.reference else args.reference_spp, "config": asdict(config),
              "rows": rows, "budgets": budgets, "verdict": found, "verdict_line": line,
              "equal_samples_line": compare_report.equal_samples_line(budgets),
              "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
              "versions": _versions(),
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
