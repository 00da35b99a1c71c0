"""``gmcpt batch SCENE --frames A:B --history N``: the frames of an animation in order, each reusing the samples
of the N frames before it (:mod:`gmcpt.sequence`).

Each frame is written as ``DIR/NAME.exr`` (R, G, B), ``.png`` and ``.json`` (parameters, versions, the frame's
history figures and stage timings), then the history to ``DIR/.sequence-state.npz``. A stopped sequence
resumes after the newest frame of that state, with the images an uninterrupted run gives; a frame whose
outputs were written but not its state is rendered again, to the same image.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .errors import GmcptError

STATE = ".sequence-state.npz"
#: the render options a sequence frame has no use for: it spends a budget on every pixel, then OIDN
UNUSED = ("rate", "spp", "time", "mask", "method", "weights", "tile")


def check(args) -> None:
    """One line for a sequence the options cannot make."""
    if not args.frames:
        raise GmcptError("--history reuses earlier frames: give --frames A:B")
    if args.ray is not None or args.sweep or len(args.scenes) != 1:
        raise GmcptError("--history renders one scene's frames in order in this process: no --ray, --sweep "
                         "or second scene")
    given = [f"--{name}" for name in UNUSED if getattr(args, name) is not None]
    if given:
        raise GmcptError(f"--history spends --budget on every pixel, then OIDN: drop {', '.join(given)}")
    from .sequence import SequenceSettings

    SequenceSettings(history=args.history)  # its one rule of the history's length


def _settings(args, scene):
    from .scene import scene_sensor
    from .sequence import SequenceSettings

    budget = args.budget if args.budget is not None else 0.3 * scene_sensor(scene).sampler().sample_count()
    return SequenceSettings(budget=budget, seed=args.seed or 0, history=args.history)


def _state_path(args) -> Path:
    return Path(args.out) / STATE


def _write_frame(job: dict, image: np.ndarray, record: dict) -> None:
    from .exr import write_exr, write_png
    from .files import json_text, write_together
    from .outputs import sidecar_paths

    exr, png, sidecar = sidecar_paths(job["out"])
    channels = {name: image[..., index] for index, name in enumerate("RGB")}
    attributes = {"gmcpt": json_text(record["parameters"], indent=None)}
    text = json_text(record)
    write_together([(exr, lambda path: write_exr(path, channels, attributes)),
                    (png, lambda path: write_png(path, image)),
                    (sidecar, lambda path: Path(path).write_text(text))])


def _save_state(args, renderer) -> None:
    from .files import atomic_output

    with atomic_output(_state_path(args)) as temporary:
        with open(temporary, "wb") as handle:
            np.savez(handle, **renderer.state())


def run(args, jobs: list[dict], say, bar) -> dict:
    """Render ``jobs`` (one scene's frames, in order) as a sequence; returns the summary rows by name."""
    from .outputs import library_versions
    from .scene import load_scene
    from .sequence import SequenceRenderer

    from .render_cli import check_nonfinite

    rows, renderer, newest = {}, None, -1
    for job in jobs:
        parameters = dict(define.split("=", 1) for define in job["options"]["defines"])
        frame = int(parameters["frame"])
        start = time.perf_counter()
        scene = load_scene(job["scene"], tuple(args.res) if args.res else None, parameters)
        if renderer is None:
            renderer = SequenceRenderer(_settings(args, scene))
            if _state_path(args).exists():
                try:
                    renderer.restore(dict(np.load(_state_path(args))))
                except (OSError, ValueError, KeyError) as error:
                    raise GmcptError(f"cannot read {_state_path(args)}: {error}; delete it to start again") from None
                newest = max((past.index for past in renderer.past), default=-1)
        if frame <= newest:
            rows[job["name"]] = {"name": job["name"], "output": job["out"], "status": "skipped", "seconds": 0.0}
            continue
        say(f"frame {frame}: {renderer.settings.budget:g} samples a pixel, {len(renderer.past)} past frames")
        try:
            image, info, timings = renderer.render(scene, frame)
            check_nonfinite(info["nonfinite_samples"], args.allow_nonfinite)
        except GmcptError as error:  # the frame's name on the one line: the frames before it are written
            raise GmcptError(f"frame {frame} ({job['name']}): {error}") from None
        record = {"scene": job["scene"], "output": str(Path(job["out"]).resolve()),
                  "parameters": {"sequence": True, "budget": renderer.settings.budget, "seed": info["seed"],
                                 "history": renderer.settings.history, "decay": renderer.settings.decay,
                                 "resolution": [image.shape[1], image.shape[0]], "scene_parameters": parameters},
                  "versions": library_versions(), **{k: v for k, v in info.items() if k != "seed"},
                  "timings": timings, "batch": {"key": job["key"], "name": job["name"]}}
        _write_frame(job, image, record)
        _save_state(args, renderer)
        seconds = time.perf_counter() - start
        rows[job["name"]] = {"name": job["name"], "output": job["out"], "status": "rendered",
                             "seconds": round(seconds, 3), "timings": timings}
        bar.update(note=f"{job['name']} {seconds:.1f}s")
    return rows

