"""``gmcpt batch SCENE --frames A:B --history N``: the frames of an animation in order, each reusing the samples
of the N frames before it (:mod:`gmcpt.temporal.sequence`).

Each frame is written as ``DIR/NAME.exr`` (R, G, B), ``.png`` and ``.json`` (parameters, versions, the frame's
history figures and stage timings), then the history to ``DIR/.sequence-state/``: a file for each past frame,
written once, and the rest, written each frame (a past frame never changes: rewriting all eight cost 60 MB a
256x256 frame, about 0.15 s of 0.8). A stopped sequence resumes after the newest frame of that state, with the
images an uninterrupted run gives; a frame whose outputs were written but not its state is rendered again, to the
same image. With ``--ray`` the frames go in
chunks, one Ray task each (:mod:`gmcpt.cli.sequence_ray`), with these files and records and no state file.
"""
from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np

from ..errors import GmcptError

STATE = ".sequence-state"
#: the state's file besides its past frames (``frame-INDEX.npz``): what the renderer keeps that changes every frame
STATE_REST = "rest.npz"
#: the render options a sequence frame has no use for: it spends a budget (or a time) on every pixel, then OIDN
UNUSED = ("rate", "spp", "mask", "method", "weights", "tile", "costs")


def default_history(args) -> int | None:
    """``--history`` when not given: :data:`~gmcpt.temporal.sequence.HISTORY_FRAMES` for the frames of one scene
    (``--frames``, no ``--sweep``) without single-frame options (:data:`UNUSED`), else none (independent frames)."""
    from ..temporal.sequence import HISTORY_FRAMES

    if args.history is not None:
        return args.history
    sequence = args.frames and not args.sweep and len(args.scenes) == 1
    return HISTORY_FRAMES if sequence and not single_frame_options(args) else None


def single_frame_options(args) -> list[str]:
    """The options given that a sequence frame has no use for (:data:`UNUSED`), as typed."""
    return [f"--{name}" for name in UNUSED if getattr(args, name) is not None]


def check(args) -> None:
    """One line for a sequence the options cannot make: one scene's ``--frames``, or an animation's scene files (one
    a frame, in the order given)."""
    if args.sweep:
        raise GmcptError("--history renders an animation's frames in order: no --sweep")
    if args.frames and len(args.scenes) != 1:
        raise GmcptError("--history renders one scene's --frames, or the scene files of one animation (a file a frame) "
                         "without --frames: not both")
    if not args.frames and len(args.scenes) < 2:
        raise GmcptError("--history reuses earlier frames: give --frames A:B, or the animation's scene files, one a "
                         "frame")
    given = single_frame_options(args)
    if given:
        raise GmcptError(f"--history spends --budget (or --time) on every pixel, then OIDN: drop {', '.join(given)}, "
                         f"or give --history 0 for independent frames")
    from ..temporal.sequence import SequenceSettings

    SequenceSettings(history=args.history)  # its one rule of the history's length


def out_of_order(scenes: list[str]) -> tuple[str, str] | None:
    """The first two of an animation's scene files (one a frame) whose order, as given, is not their names' order
    with numbers read as numbers (a shell's ``shot-*.xml`` puts shot-10 before shot-2); None where it is."""
    def key(name: str) -> list:
        return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", Path(name).name)]

    return next(((a, b) for a, b in zip(scenes, scenes[1:]) if key(b) < key(a)), None)


def sequence_settings(args, scene):
    """The sequence's settings (:class:`~gmcpt.temporal.sequence.SequenceSettings`) from the command's arguments."""
    from ..render.scene import scene_sensor
    from ..temporal.sequence import SequenceSettings, sequence_budget

    return SequenceSettings(budget=sequence_budget(args.budget, scene_sensor(scene)), seed=args.seed or 0,
                            history=args.history, time=args.time or 0.0)


def _state_path(args) -> Path:
    return Path(args.out) / STATE


def frame_parameters(job: dict) -> dict[str, str]:
    """``job``'s ``$`` parameters (``frame`` among them)."""
    return dict(define.split("=", 1) for define in job["options"]["defines"])


def scene_frames(args, job: dict):
    """The frames of ``job``'s scene file at ``--res`` as one held scene
    (:class:`~gmcpt.render.frames.SceneFrames`): what every sequence path takes its frames from. A frame sets what
    changed since the frame before, so that the kernels recorded for the first frame serve the next ones."""
    from ..render.frames import SceneFrames

    return SceneFrames(job["scene"], tuple(args.res) if args.res else None)


def frame_scene(frames, job: dict) -> tuple:
    """(scene, its ``$`` parameters, the seconds it took to set or load) of ``job`` (its scene file, its parameters)
    from ``frames`` (:func:`scene_frames`)."""
    parameters = frame_parameters(job)
    start = time.perf_counter()
    try:
        scene = frames.at(parameters, job["scene"])
    except GmcptError as error:  # the frame's name on the one line: the frames before it are written
        raise GmcptError(f"frame {job['frame']} ({job['name']}): {error}") from None
    return scene, parameters, time.perf_counter() - start


def render_frame(args, renderer, job: dict, scene, parameters: dict, scene_seconds: float) -> tuple[np.ndarray, dict]:
    """``job``'s frame as ``renderer``'s next: (image, its JSON record; its timings begin with ``scene_s``, the
    seconds its scene took to set or load). One record for the one-process and the Ray paths, so a frame's files do
    not say where it was rendered; a failure names the frame on its one line."""
    from ..io.outputs import library_versions
    from .render import check_nonfinite

    frame = job["frame"]
    try:
        image, info, timings = renderer.render(scene, frame)
        check_nonfinite(info.nonfinite_samples, args.allow_nonfinite)
    except GmcptError as error:  # the frame's name on the one line: the frames before it are written
        raise GmcptError(f"frame {frame} ({job['name']}): {error}") from None
    settings = renderer.settings
    record = {"scene": job["scene"], "output": str(Path(job["out"]).resolve()),
              "parameters": {"sequence": True, "budget": settings.budget, "seed": info.seed,
                             "history": settings.history, "decay": settings.decay, "time": settings.time or None,
                             "resolution": [image.shape[1], image.shape[0]], "scene_parameters": parameters},
              "versions": library_versions(), **info.to_json(),
              "timings": {"scene_s": scene_seconds, **timings}, "batch": {"key": job["key"], "name": job["name"]}}
    return image, record


def frame_row(job: dict, status: str, seconds: float = 0.0, timings: dict | None = None) -> dict:
    """``job``'s row of the batch summary."""
    row = {"name": job["name"], "output": job["out"], "status": status, "seconds": round(seconds, 3)}
    return row if timings is None else {**row, "timings": timings}


def write_frame(job: dict, image: np.ndarray, record: dict) -> None:
    """``job``'s EXR (R, G, B; the record's parameters in its header), PNG and JSON record, all or none."""
    from ..io.exr import write_exr, write_png
    from ..io.files import json_text, write_together
    from ..io.outputs import sidecar_paths

    exr, png, sidecar = sidecar_paths(job["out"])
    channels = {name: image[..., index] for index, name in enumerate("RGB")}
    attributes = {"gmcpt": json_text(record["parameters"], indent=None)}
    text = json_text(record)
    write_together([(exr, lambda path: write_exr(path, channels, attributes)),
                    (png, lambda path: write_png(path, image)),
                    (sidecar, lambda path: Path(path).write_text(text))])


def _save_state(args, renderer) -> None:
    """The renderer's state in parts: each past frame's arrays (:meth:`~gmcpt.temporal.history.PastFrame.arrays`) to
    a file of its own, written once; the rest (:meth:`~gmcpt.temporal.sequence.SequenceRenderer.rest_state`), with
    the past frames' indices in order, to :data:`STATE_REST`, written after them; then the files of frames that left
    the history go."""
    folder = _state_path(args)
    try:
        folder.mkdir(exist_ok=True)
    except OSError as error:
        raise GmcptError(f"cannot write the sequence's state in {folder}: {error.strerror or error}") from None
    indices = [past.index for past in renderer.past]
    for past in renderer.past:
        # the newest always: a file a stopped run left of it may hold another render (a timed frame's)
        if past.index == indices[-1] or not (folder / _frame_file(past.index)).exists():
            _save_arrays(folder / _frame_file(past.index), past.arrays())
    _save_arrays(folder / STATE_REST, {**renderer.rest_state(), "frames": np.array(indices, np.int64)})
    for stale in set(folder.glob("frame-*.npz")) - {folder / _frame_file(index) for index in indices}:
        stale.unlink(missing_ok=True)


def _restore_state(args, renderer) -> None:
    """Give ``renderer`` back what :func:`_save_state` wrote."""
    folder = _state_path(args)
    with np.load(folder / STATE_REST) as saved:
        rest = {key: saved[key] for key in saved.files}
    pasts = []
    for index in rest.pop("frames"):
        with np.load(folder / _frame_file(int(index))) as arrays:
            pasts.append({name: arrays[name] for name in arrays.files})
    renderer.restore_parts(pasts, rest)


def _frame_file(index: int) -> str:
    return f"frame-{index:06d}.npz"


def _save_arrays(path: Path, arrays: dict) -> None:
    from ..io.files import atomic_output

    with atomic_output(path) as temporary:
        with open(temporary, "wb") as handle:
            np.savez(handle, **arrays)


def run(args, jobs: list[dict], say, bar) -> dict:
    """Render ``jobs`` (an animation's frames, in order: one scene's ``--frames``, or its files) as a sequence;
    returns the summary rows by name."""
    from ..temporal.sequence import SequenceRenderer

    rows, renderer, newest, frames = {}, None, -1, scene_frames(args, jobs[0])
    for job in jobs:
        start, loaded = time.perf_counter(), None
        if renderer is None:  # the first frame's scene gives the settings (a resumed run's too: it sets the next)
            loaded = frame_scene(frames, job)
            renderer = SequenceRenderer(sequence_settings(args, loaded[0]))
            if (_state_path(args) / STATE_REST).exists():
                try:
                    _restore_state(args, renderer)
                except (OSError, ValueError, KeyError) as error:
                    raise GmcptError(f"cannot read {_state_path(args)}: {error}; delete it to start again") from None
                except GmcptError as error:  # another budget, seed or history: its frames would not match
                    raise GmcptError(f"{_state_path(args)}: {error}: delete it, or give another --out") from None
                newest = max((past.index for past in renderer.past), default=-1)
        if job["frame"] <= newest:
            rows[job["name"]] = frame_row(job, "skipped")
            continue
        loads = frames.loads
        scene, parameters, scene_seconds = loaded or frame_scene(frames, job)
        whole = f"; its scene loaded whole: {frames.whole_reason}" if frames.loads > max(loads, 1) else ""
        settings = renderer.settings
        spends = f"{settings.time:g} s" if settings.time else f"{settings.budget:g} samples a pixel"
        say(f"frame {job['frame']}: {spends}, {len(renderer.past)} past frames{whole}")
        image, record = render_frame(args, renderer, job, scene, parameters, scene_seconds)
        write_frame(job, image, record)
        _save_state(args, renderer)
        seconds = time.perf_counter() - start
        rows[job["name"]] = frame_row(job, "rendered", seconds, record["timings"])
        bar.update(note=f"{job['name']} {seconds:.1f}s")
    return rows
