"""``gmcpt eval``: run the evaluation and regenerate ``docs/results.md``, its plots and the README section.

    gmcpt eval --quick          # under 10 minutes on 2 CPU cores once references are cached
    gmcpt eval                  # full mode
    gmcpt eval --quick --out /tmp/eval --no-readme
    gmcpt eval --from docs/results.json   # rewrite results.md, its plots and the README's parts, no measuring

References (4096 spp, and a second independent one per scene for its noise
level) are rendered on the first run and cached (``gmcpt.evaluation.reference``);
rendering them takes tens of minutes, printed as it goes. A stopped run resumes after its last finished scene
(:mod:`gmcpt.evaluation.checkpoint`).
"""
from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import os
import platform
import subprocess
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

from ..errors import GmcptError
from ..evaluation import checkpoint
from ..evaluation.config import CONFIGS
from ..evaluation.scenes import evaluation_scenes
from ..io.exr import atomic_output, check_writable
from ..seeds import SECOND_REFERENCE_SEED
from .command import Parser

ROOT = Path(__file__).resolve().parents[2]
#: the full-resolution check's name among a checkpoint's finished parts
FULL_RESOLUTION = "full resolution"


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("eval", "Measure the completion methods against references; rewrite docs/results.md, its "
                    "plots and the README's results.\nReferences are rendered once (tens of minutes), then cached; "
                    "a stopped run resumes after its last finished scene.")
    parser.add_argument("--quick", action="store_true", help="the quick configuration (default: full)")
    parser.add_argument("--out", default=str(ROOT / "docs"), help="folder of results.md, results.json, plots")
    parser.add_argument("--scenes", nargs="+",
                        help="named scenes of gmcpt.evaluation.scenes (default: the quality scenes)")
    parser.add_argument("--procedural", type=int, help="held-out procedural scenes (default: the configuration's)")
    parser.add_argument("--readme", default=str(ROOT / "README.md"), help="README whose results section to rewrite")
    parser.add_argument("--no-readme", dest="readme", action="store_const", const=None,
                        help="leave the README alone (default: rewrite its results section)")
    parser.add_argument("--from", dest="record", metavar="RESULTS.json",
                        help="measure nothing: rewrite the documents and plots from a recorded run (default: measure)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def _commit() -> str:
    try:
        out = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty"], capture_output=True,
                             text=True, timeout=10)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def run_versions() -> dict:
    from importlib import metadata

    from ..io.outputs import library_versions

    versions = library_versions()
    for package in ("flip-evaluator", "pyoidn"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "not installed"
    return versions


def machine_line() -> str:
    """This machine in the words of a record: architecture, cores, system."""
    return f"{platform.machine()}, {os.cpu_count()} CPU cores, {platform.system()}, no GPU used"


def _write_text(path: Path, text: str) -> None:
    with atomic_output(path) as temporary:
        Path(temporary).write_text(text)


def write_documents(record: dict, out: Path, readme: str | None) -> None:
    """``results.md`` and the README's generated parts (results, limits) from a run's record, with the sequence
    benchmark's record where ``out`` has one (``sequences.json``, from ``benchmarks/sequence.py --record``)."""
    from ..evaluation.document import results_markdown, rewrite_readme

    sequences = out / "sequences.json"
    if sequences.is_file():
        record = {**record, "sequences": json.loads(sequences.read_text())}
    _write_text(out / "results.md", results_markdown(record))
    if readme:
        path = Path(readme)
        _write_text(path, rewrite_readme(path.read_text() if path.is_file() else "", record))


def _recorded(path: str) -> dict:
    """The record of an earlier run (``--from``), refused in one line if it is not one."""
    try:
        record = json.loads(Path(path).read_text())
    except OSError as error:
        raise GmcptError(f"--from {path}: {error.strerror}") from None
    except ValueError as error:
        raise GmcptError(f"--from {path} is not JSON: {error}") from None
    missing = [key for key in ("config", "quality", "equal_time", "references", "command") if key not in record]
    if not isinstance(record, dict) or missing:
        raise GmcptError(f"--from {path} is not the results.json of an evaluation (no {', '.join(missing)})")
    return record


def evaluate(config, scenes, out: Path, say, quiet: bool = False, resume: dict | None = None) -> dict:
    """Measure everything, write the plots, return the run's record (rows, settings, versions).

    Progress: a bar over the scenes on a terminal (``say``'s lines above it), else ``say``'s lines. With a
    ``resume`` key (:func:`checkpoint.resume_key`) each finished scene is checkpointed in ``out``, and a run with
    the same key starts after the last one checkpointed.
    """
    from ..runtime.progress import Progress
    from ..evaluation import measure, plots

    start = time.perf_counter()
    record = checkpoint.load(out, resume)
    if record is not None:
        say(f"resuming from {out / checkpoint.PARTIAL}: {', '.join(record['done']) or 'no scene'} measured")
    else:
        record = {"config": asdict(config), "second_reference_seed": SECOND_REFERENCE_SEED, "references": [],
                  "quality": [], "placement": [], "equal_time": [], "full_resolution": [], "stage_timings": [],
                  "grids": {}, "real_scenes": [scene.name for scene in scenes if scene.real],
                  "credits": {scene.name: scene.credit for scene in scenes if scene.credit}, "done": [],
                  "seconds": 0.0, "runs": 0}
    record["runs"] += 1
    earlier = record["seconds"]

    def finished(name: str) -> None:
        record["done"].append(name)
        record["seconds"] = earlier + time.perf_counter() - start
        checkpoint.save(out, resume, record)

    with Progress(len(scenes), "eval", unit="scene", say=say, quiet=quiet) as bar:
        say = bar.write
        for index, eval_scene in enumerate(scenes, 1):
            if eval_scene.name in record["done"]:
                bar.update(note=eval_scene.name)
                continue
            tagged = lambda rows: [dict(row, real=eval_scene.real) for row in rows]  # noqa: E731
            say(f"[{index}/{len(scenes)}] {eval_scene.name}: references")
            loaded, noise = measure.load(eval_scene, config, say)
            record["references"].append(noise)
            say(f"[{index}/{len(scenes)}] {eval_scene.name}: quality at rates {', '.join(map(str, config.rates))}")
            record["quality"] += tagged(measure.quality(loaded, config, say))
            say(f"[{index}/{len(scenes)}] {eval_scene.name}: sample placement at equal samples")
            record["placement"] += tagged(measure.placement(loaded, config, say))
            say(f"[{index}/{len(scenes)}] {eval_scene.name}: equal-time settings (warm)")
            record["equal_time"] += tagged(measure.equal_time(loaded, config, say))
            grid = f"grid-{eval_scene.name}.png"
            title = f"{eval_scene.name}, rate {config.grid_rate:g} x {config.spp} spp"
            plots.image_grid(loaded.images, out / grid, title)
            record["grids"][eval_scene.name] = grid
            finished(eval_scene.name)
            bar.update(note=eval_scene.name)
        full_scene = next((s for s in scenes if s.name == config.full_scene), None)
        if full_scene is None:
            say(f"skipping the full-resolution check: {config.full_scene} is not among the scenes")
        elif FULL_RESOLUTION not in record["done"]:
            say(f"full resolution: {full_scene.name} at {'x'.join(map(str, config.full_size))}")
            record["full_resolution"] = measure.full_resolution(full_scene, config, say)
            finished(FULL_RESOLUTION)
        timing_scene = next((s for s in scenes if s.name == config.timing_scene), scenes[0])
        say(f"stage timings on {timing_scene.name} at {', '.join(map(str, config.timing_resolutions))} px")
        record["stage_timings"] = measure.stage_timings(timing_scene, config, say)
    plots.write_plots(record, out)
    record["seconds"] = earlier + time.perf_counter() - start
    return record


def main(argv: list[str] | None = None) -> int:
    from .command import stamped_say

    try:
        args = build_parser().parse_args(argv)
        say = stamped_say("eval", args.quiet)
        config = CONFIGS["quick" if args.quick else "full"]
        if args.procedural is not None:
            if args.procedural < 0:
                raise GmcptError("--procedural must be >= 0")
            config = replace(config, procedural=args.procedural)
        skipped = []  # said after every check, so that a refusal stays one line
        scenes = evaluation_scenes(args.scenes, config.procedural, skipped.append)
        if not scenes:
            raise GmcptError("no evaluation scene is available")
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            raise GmcptError(f"--out {out} is not a folder")
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise GmcptError(f"cannot create {out}: {error.strerror}") from None
        for path in [out / "results.md", out / "results.json"] + ([Path(args.readme)] if args.readme else []):
            check_writable(path)
        if importlib.util.find_spec("pyoidn") is None:  # found, not imported: importing it loads torch (2 s)
            raise GmcptError("the evaluation's denoiser baseline needs pyoidn: pip install -e '.[dev]'")
        if args.record:
            from ..evaluation.plots import write_plots

            record = _recorded(args.record)
            write_plots(record, out)
            write_documents(record, out, args.readme)
            say(f"rewrote {out / 'results.md'} and its plots from {args.record}"
                + (f"; updated {args.readme}" if args.readme else ""))
            return 0
        for line in skipped:
            say(line)

        import gmcpt  # noqa: F401  (LLVM, variant)
        import mitsuba as mi
        mi.set_log_level(mi.LogLevel.Error)
        commit = _commit()  # before the run rewrites docs/
        resume = checkpoint.resume_key(config, scenes, checkpoint.code_version(ROOT))
        record = evaluate(config, scenes, out, say, quiet=args.quiet, resume=resume)
        record.update(command="python -m gmcpt eval" + (" --quick" if args.quick else ""),
                      date=datetime.date.today().isoformat(), commit=commit, versions=run_versions(),
                      machine=machine_line())
        if args.scenes or args.procedural is not None:
            record["command"] += "".join([f" --scenes {' '.join(args.scenes)}" if args.scenes else "",
                                          f" --procedural {args.procedural}" if args.procedural is not None else ""])
        _write_text(out / "results.json", json.dumps(record, indent=1, default=float) + "\n")
        write_documents(record, out, args.readme)
        checkpoint.discard(out)
        say(f"wrote {out / 'results.md'}, results.json and plots" + (f"; updated {args.readme}" if args.readme else ""))
        return 0
    except GmcptError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        return 130
