"""``gmcpt batch``: render and complete many scenes or frames, here or on a Ray cluster.

    gmcpt batch scenes/*/scene.xml --out out/batch --rate 0.3
    gmcpt batch anim.xml --frames 0:240 --out out/anim --ray local
    gmcpt batch scene.xml --sweep seed=0,1,2,3 --out out/seeds --ray HEAD:6379

Each frame is one single render (:func:`gmcpt.cli.render.run`, the same options)
written as ``DIR/NAME.exr``, ``.png`` and ``.json``; NAME is the scene's
folder (its file name unless it is ``scene.xml``) with the frame's swept
parameters appended (``anim_frame-0012``). ``DIR/batch-summary.json``
collects every frame's timings. A frame whose three files exist and whose
record carries the same request (scene file, options) is skipped, so a
stopped batch resumes; frames are written atomically by
:func:`gmcpt.io.outputs.write_outputs`.

A frame's completed pixels depend, in the last bit, on the number of torch
threads (PAWNNM sums per-thread partial results), so every frame runs on
``--threads`` torch threads wherever it runs: with ``--ray`` the files are
bit for bit those of the run in one process.
"""
from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import os
import re
import sys
import time
from pathlib import Path
from typing import Callable

from ..errors import GmcptError
from ..runtime import interrupts
from .batch_records import CRASH_ONCE, crash_once, finished_record  # noqa: F401 (CRASH_ONCE: tests)
from .command import Parser, mitsuba_command, stamped_say, start_mitsuba
from .render import add_render_options, run, validate

SUMMARY = "batch-summary.json"


def _render_dests() -> list[str]:
    return [action.dest for action in add_render_options(argparse.ArgumentParser())._actions
            if action.dest not in ("help", "quiet")]


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("batch", "Render and complete many scenes, frames or parameter sweeps, here or on a Ray "
                    "cluster.\nEach frame is one gmcpt render, written as DIR/NAME.exr, .png and .json; a stopped "
                    "batch resumes.")
    parser.add_argument("scenes", nargs="+", metavar="SCENE", help="Mitsuba 3 scene XML files")
    parser.add_argument("--out", required=True, help="output folder (required; created if its parent exists): "
                        "NAME.exr, .png, .json per frame")
    add_render_options(parser)
    parser.add_argument("--frames", metavar="START:STOP", help="one frame per $frame value START..STOP-1, as "
                        "--sweep frame=START,...,STOP-1 (default: none)")
    parser.add_argument("--sweep", action="append", default=[], metavar="NAME=V1,V2,...",
                        help="one frame per value of scene parameter $NAME; several sweeps multiply (default: none)")
    parser.add_argument("--history", type=int, metavar="N", help="a sequence: the frames in order, each reusing "
                        "the samples of the N frames before it, then OIDN; spends --budget or --time a frame; 0: "
                        "independent frames, as are those of --sweep, of several scenes or with a single-frame "
                        "option such as --rate or --spp (default: 8)")
    parser.add_argument("--chunk", type=int, metavar="N", help="a sequence on Ray: N consecutive frames a task, "
                        "each task first rendering the --history frames (and 2 more) before its own unwritten "
                        "(default: the frames over the workers, at least 2 x --history)")
    parser.add_argument("--threads", type=int, default=1,
                        help="CPU threads of one frame: torch's everywhere, Dr.Jit's and the Ray task's CPUs on Ray")
    parser.add_argument("--ray", metavar="ADDRESS", help="run frames as Ray tasks: local (start a cluster here), "
                        "auto, HOST:PORT, ray://HOST:PORT (default: in this process)")
    parser.add_argument("--gpus", type=float, help="GPUs per Ray task (default: 1 where the cluster has GPUs)")
    parser.add_argument("--retries", type=int, default=3, help="runs of a Ray task again when its worker dies")
    parser.add_argument("--video", metavar="OUT.mp4", help="also write the frames' PNGs, in order and of one size, "
                        "as an H.264 movie in sRGB, once all are there (default: none)")
    parser.add_argument("--fps", type=float, default=24, help="frames a second of --video")
    return parser


def scene_name(path: str | os.PathLike) -> str:
    """``scenes/cornell-box/scene.xml`` -> ``cornell-box``; ``shots/a.xml`` -> ``a``."""
    path = Path(path)
    return path.parent.resolve().name if path.stem == "scene" else path.stem


def sweep_points(sweeps: list[str], frames: str | None = None) -> list[tuple[tuple[str, str], ...]]:
    """Every combination of the swept parameters' values, in order; ``[()]`` without sweeps."""
    axes = []
    if frames is not None:
        match = re.fullmatch(r"(-?\d+):(-?\d+)", frames)
        if not match or int(match[1]) >= int(match[2]):
            raise GmcptError(f"--frames expects START:STOP with START < STOP, got {frames!r}")
        axes.append([("frame", str(i)) for i in range(int(match[1]), int(match[2]))])
    for sweep in sweeps:
        name, _, values = sweep.partition("=")
        if not re.fullmatch(r"[A-Za-z_]\w*", name) or not values or "" in values.split(","):
            raise GmcptError(f"--sweep expects NAME=V1,V2,..., got {sweep!r}")
        axes.append([(name, value) for value in values.split(",")])
    names = [axis[0][0] for axis in axes]
    if len(set(names)) < len(names):
        raise GmcptError(f"a parameter is swept twice: {', '.join(names)}")
    return list(itertools.product(*axes))


def frame_name(scene: str, point: tuple[tuple[str, str], ...]) -> str:
    """Output name of one frame: ``scene_frame-0003_seed-1`` (digits padded to 4, odd characters as ``_``)."""
    parts = [scene] + [f"{name}-{value.zfill(4) if value.isdigit() else value}" for name, value in point]
    return "_".join(re.sub(r"[^A-Za-z0-9.+-]", "_", part) for part in parts)


def request_key(scene: Path, options: dict) -> str:
    """sha256 of what fixes a frame's pixels: the scene file's bytes and the render options."""
    digest = hashlib.sha256(scene.read_bytes())
    digest.update(json.dumps(options, sort_keys=True).encode())
    return digest.hexdigest()


def plan(args) -> list[dict]:
    """One job (a dict; it travels to Ray workers) per scene and sweep point, in order."""
    from ..render.scene import check_animated, check_scene_file

    options = {dest: getattr(args, dest) for dest in _render_dests()}
    jobs, seen = [], {}
    for scene in args.scenes:
        path = check_animated(scene) if args.frames else check_scene_file(scene)
        for point in sweep_points(args.sweep, args.frames):
            name = frame_name(scene_name(path), point)
            if name in seen or name == Path(SUMMARY).stem:
                raise GmcptError(f"{scene} and {seen.get(name, 'the summary')} both write {name}.exr; "
                                 f"give the scene files distinct names")
            seen[name] = scene
            frame_options = {**options, "defines": options["defines"] + [f"{k}={v}" for k, v in point]}
            # a sequence's frame number: its $frame, else its place (an animation given as one scene file a frame)
            frame = int(dict(point).get("frame", len(jobs)))
            jobs.append({"name": name, "scene": str(path.resolve()), "out": str(Path(args.out).resolve() / f"{name}.exr"),
                         "options": frame_options, "key": request_key(path, frame_options), "threads": args.threads,
                         "render_threads": args.threads if args.ray else 0, "frame": frame})
    return jobs


def job_args(job: dict) -> argparse.Namespace:
    """The single render's arguments of ``job`` (what :func:`gmcpt.cli.render.run` takes)."""
    return argparse.Namespace(scene=job["scene"], out=job["out"], reference=None, quiet=True, **job["options"])


def _row(job: dict, record: dict, status: str, seconds: float) -> dict:
    return {"name": job["name"], "scene": job["scene"], "output": job["out"], "status": status,
            "seconds": round(seconds, 3), "timings": record.get("timings", {}), "host": os.uname().nodename,
            "pid": os.getpid()}


def render_job(job: dict) -> dict:
    """Render, complete and write one frame unless it is already there; returns its summary row.

    Runs in the driver or as a Ray task: ``job["threads"]`` torch threads (and, on Ray,
    ``job["render_threads"]`` Dr.Jit threads) whichever it is.
    """
    start = time.perf_counter()
    start_mitsuba()
    import torch

    torch.set_num_threads(job["threads"])
    if job["render_threads"]:
        import drjit as dr
        dr.set_thread_count(job["render_threads"])
    record = finished_record(job)  # a retried task whose first run got as far as writing
    if record is not None:
        return _row(job, record, "found", time.perf_counter() - start)
    crash_once()
    record = run(job_args(job), extra={"batch": {"key": job["key"], "name": job["name"]}})
    return _row(job, record, "rendered", time.perf_counter() - start)


def _prepare_out(out: Path) -> bool:
    """Create the output folder if needed; True if this call created it."""
    if out.exists():
        if not out.is_dir():
            raise GmcptError(f"--out {out} is not a folder")
        return False
    if not out.parent.is_dir():
        raise GmcptError(f"output directory {out.parent} does not exist")
    try:
        out.mkdir()
    except OSError as error:
        raise GmcptError(f"cannot create {out}: {error.strerror}") from None
    return True


def _validate_batch(args) -> list[dict]:
    from ..runtime.cluster import check_address, check_reachable

    if args.threads < 1:
        raise GmcptError(f"--threads must be >= 1, got {args.threads}")
    if args.retries < 0 or (args.gpus is not None and args.gpus < 0):
        raise GmcptError("--retries and --gpus must be >= 0")
    if args.video is not None:
        from ..io.video import check_fps, check_video_path
        check_video_path(args.video, "--video")
        check_fps(args.fps, "--fps")
    from .sequence_batch import check, default_history
    from .sequence_ray import check as check_chunks

    args.history = default_history(args)
    if args.history == 0:
        args.history = None  # independent frames
    if args.history is None and getattr(args, "chunk", None) is not None:
        raise GmcptError("--chunk splits a sequence into Ray tasks; independent frames are a task each: drop it")
    if args.history is not None:
        check(args)
        check_chunks(args)
    jobs = plan(args)
    if args.ray is not None:
        check_reachable(check_address(args.ray))
    created = _prepare_out(Path(args.out))
    try:
        for job in jobs:
            validate(job_args(job))
    except GmcptError:
        if created:
            Path(args.out).rmdir()
        raise
    return jobs


def _results(args, todo: list[dict]):
    if args.ray is None:
        yield from map(render_job, todo)
        return
    from ..runtime.cluster import connected, default_gpus, run_tasks

    with connected(args.ray, quiet=args.quiet) as resources:
        gpus = default_gpus(resources) if args.gpus is None else args.gpus
        yield from run_tasks(render_job, todo, cpus=args.threads, gpus=gpus, max_retries=args.retries)


def batch(args, say=lambda message: None, committed: Callable[[], None] | None = None) -> dict:
    """Run the batch ``args`` describes; returns the summary (also written to ``DIR/batch-summary.json``).

    ``committed`` runs once the summary, the batch's last output, is in place.
    """
    from ..runtime.progress import Progress

    started = time.perf_counter()
    jobs = _validate_batch(args)
    if args.history is not None:
        from . import sequence_batch, sequence_ray

        say(f"{len(jobs)} frames as a sequence" + ("" if args.frames else " (a scene file a frame, in the order given)")
            + f", each reusing up to {args.history} earlier frames")
        swapped = None if args.frames else sequence_batch.out_of_order(args.scenes)
        if swapped:
            print(f"warning: {swapped[0]} comes before {swapped[1]}: the frames are rendered in the order given "
                  f"(number the files with leading zeros, or list them in order)", file=sys.stderr)
        with Progress(len(jobs), "sequence", unit="frame", say=say, quiet=args.quiet) as bar:
            rows = (sequence_batch.run if args.ray is None else sequence_ray.run)(args, jobs, say, bar)
        return _summary(args, jobs, rows, started, committed)
    if args.frames:
        from .sequence_batch import single_frame_options

        given = single_frame_options(args)
        say("independent frames" + (f": {', '.join(given)} is for single frames (a sequence spends --budget or "
                                    f"--time)" if given else ""))
    rows = {}
    for job in jobs:
        record = finished_record(job)
        if record is not None:
            rows[job["name"]] = _row(job, record, "skipped", 0.0)
    todo = [job for job in jobs if job["name"] not in rows]
    say(f"{len(jobs)} frames, {len(rows)} already complete, {len(todo)} to render "
        + (f"on Ray ({args.ray})" if args.ray else "in this process"))
    with Progress(len(todo), "batch", unit="frame", say=say, quiet=args.quiet) as bar:
        for row in _results(args, todo):
            rows[row["name"]] = row
            bar.update(note=f"{row['name']} {row['seconds']:.1f}s")
    return _summary(args, jobs, rows, started, committed)


def _movie(args, jobs: list[dict]) -> None:
    """``--video``: the frames' PNG previews, in the jobs' order, as one movie (:func:`gmcpt.io.video.write_video`)."""
    from ..io.files import make_folder
    from ..io.outputs import sidecar_paths
    from ..io.video import write_video

    make_folder(args.video)
    write_video((sidecar_paths(job["out"])[1] for job in jobs), args.video, args.fps)


def _summary(args, jobs: list[dict], rows: dict, started: float, committed) -> dict:
    """Write and return ``DIR/batch-summary.json`` of ``rows`` (by frame name), in the jobs' order; the movie
    (``--video``) first, so that the summary stays the batch's last output."""
    from ..io.exr import atomic_output

    if getattr(args, "video", None) is not None:
        _movie(args, jobs)
    ordered = [rows[job["name"]] for job in jobs]
    summary = {"command": "gmcpt batch " + " ".join(getattr(args, "argv", [])), "ray": args.ray,
               "threads": args.threads, "frames": len(jobs),
               "rendered": sum(row["status"] != "skipped" for row in ordered),
               "skipped": sum(row["status"] == "skipped" for row in ordered),
               "wall_s": round(time.perf_counter() - started, 3),
               "frame_seconds": round(sum(row["seconds"] for row in ordered if row["status"] != "skipped"), 3),
               "items": ordered}
    with atomic_output(Path(args.out) / SUMMARY, committed) as temporary:
        Path(temporary).write_text(json.dumps(summary, indent=1) + "\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt batch``; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)

    def work(args) -> int:
        args.argv = argv
        summary = batch(args, stamped_say("batch", args.quiet), committed=interrupts.settle)
        print(json.dumps({key: value for key, value in summary.items() if key != "items"}))
        return 0
    return mitsuba_command(argv, build_parser, work)


if __name__ == "__main__":
    sys.exit(main())
