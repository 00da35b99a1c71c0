#!/usr/bin/env python3
"""Sequences: the sequence mode against per-frame path tracing + OIDN and temporal accumulation + OIDN.

An evaluation scene changes over ``--frames`` frames in each ``--motion`` in turn (``--step MOTION=VALUE`` sets the
pace of ``pan``, ``dolly`` and ``light``):

- ``pan``: the camera turns about its own up axis, 0.5 degrees a frame;
- ``dolly``: the camera moves along its view, 0.5 hundredths of a scene unit a frame;
- ``object``: the camera stays; one object of the room (:data:`MOVING_OBJECTS`: the living room's table with its
  bottle and glasses, the dining and breakfast rooms' front left chair) slides sideways at its own pace, about
  2 pixels a frame at 256x256, and its shadow with it;
- ``light``: the camera stays; the scene's main light (the living room's sky, the dining room's sun, the breakfast
  room's sun sphere) turns about the vertical through the scene's centre, 1 degree a frame: the sun's patches and
  the shadows move across the room;
- ``still``: nothing moves.

A motion sets the scene's parameters through ``mi.traverse``, made opaque (``dr.make_opaque``) so that a new frame
compiles no kernel of its own, and the contenders and the references see the same scene at each frame. Where shapes
move (``object``, a light that is a shape), gmcpt's frozen kernels run as plain Dr.Jit code, as ``mi.render`` does
(:class:`gmcpt.render.kernels.FrozenKernel`). Each frame has two independent
references (``--reference-spp`` each, cached under the motion; PSNR is read against their mean). Contenders, each
at a ladder of samples a pixel a frame:

- ``path+oidn`` (``--path-spp``): every frame on its own, as a Mitsuba user denoises it: ``mi.render`` at the
  samples, then one pass of Mitsuba's ``aov`` integrator (albedo, shading normal) at as many samples whose images
  are OIDN's guides (the albedo clipped to [0, 1], OIDN's range), then OIDN; all three timed;
- ``lightpath+oidn`` (``--light-spp``): the same, its paths taking the sequence mode's emitter samples at their
  first hit (``LIGHT_SAMPLES``): what that estimator alone buys a frame on its own, so that the sequence's own share
  of its speed-up shows;
- ``accumulation+oidn`` (``--path-spp``): the same samples averaged with the previous frames' accumulated image,
  reprojected to the nearest pixel with the depth and normal tests of :mod:`gmcpt.temporal.history`, an exponential
  moving average (weight ``max(1 / n, 0.2)`` for the new samples, n the pixel's history length), then the same guides
  and OIDN: SVGF's accumulation, the strongest simple alternative;
- ``sequence`` (``--budgets``): :class:`gmcpt.temporal.sequence.SequenceRenderer` at the same budget.

The contenders take turns frame by frame, so a machine whose pace drifts slows them alike. Before them the
sequences run once through the frames untimed: a sequence's memory grows with its history through its first frames,
and on a virtual machine that backs memory on first touch (this project's: 64 MB new to the process in about 170 ms,
reused in 12) that growth, not the mode, would be timed (docs/experiments.md). Printed per scene,
motion and setting, over the frames after the first ``--warm`` (history needs frames to build): mean PSNR;
``psnr_changed``, the PSNR over the pixels whose true image changed since the frame before (a moving object's old
and new place, its shadow, a light's patches, what a camera move uncovers: where stale history shows;
:func:`gmcpt.evaluation.stability.changed_pixels`), pooled over the frames, with the share of such pixels; mean warm
time a frame; the flicker figures of :mod:`gmcpt.evaluation.stability` (``flicker``: the error of frame-to-frame
changes along the camera's motion; ``screen_flicker``: in place; both read against the two references, so their
noise is no floor). Then per baseline: the equal-time speed-up of the sequence mode over it
(:func:`gmcpt.evaluation.report.equal_time_verdict`), its flicker over the baseline's at the same seconds a frame,
and its ``psnr_changed`` minus the baseline's at the same seconds (``changed_gap_db``: below 0 the sequence is
behind where the scene changed; :mod:`gmcpt.evaluation.sequences`).

    python benchmarks/sequence.py [--scenes living-room] [--frames 12] [--res 128] [--motion pan object]
        [--step pan=0.5 light=1] [--record docs/sequences.json]

``--record``: the rows, the verdicts and the settings as JSON, a plot beside it (``.png``); ``--merge PART.json ...
--record OUT.json`` joins runs on other scenes into one record; ``gmcpt eval --from docs/results.json`` then puts
them in ``docs/results.md``. ``--references-only`` renders and caches the references alone (untimed: a busy machine
may do it), so that a later run on a quiet machine only measures.
"""
from __future__ import annotations

import argparse
import sys
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ACCUMULATION_MIN_WEIGHT = 0.2
MOTIONS = ("pan", "dolly", "object", "light", "still")
#: The pace of the motions that ``--step`` sets: degrees a frame (pan, light), hundredths of a unit (dolly).
DEFAULT_STEPS = {"pan": 0.5, "dolly": 0.5, "light": 1.0}
#: The vertical axis of the evaluation's real scenes (their floors are level in y), about which a light turns.
UP = np.array([0.0, 1.0, 0.0])


@dataclass(frozen=True)
class MovingObject:
    """One object of a scene that the ``object`` motion slides: its meshes (Mitsuba names an imported OBJ mesh by
    its file; the real scenes' shapes have no ids), a unit direction in world space and its pace a frame."""

    name: str  # in words
    meshes: tuple[str, ...]
    direction: tuple[float, float, float]
    step: float  # scene units a frame

    def label(self) -> str:
        """What the references' cache is keyed by: the object, its direction and pace (and that its meshes keep
        their normals as they move: the references before that had Mitsuba's smooth ones)."""
        return f"object{zlib.crc32((repr(self) + ' file normals').encode()):08x}"


#: Per scene, the object that slides: in plain view, mid-sized, casting a shadow where the light falls. The living
#: room's round table (top, stem, foot) with its bottle and glasses stands in the sun's patch before the windows
#: and moves to the left across it (metres, 4 cm a frame); the dining and breakfast rooms (one model, lit by a sun
#: from the right) move their front left chair (shell and chrome legs) to the left along the table, its shadow on
#: the floor beside it (6 hundredths of a unit a frame). About 2 pixels a frame at 256x256 in each.
FRONT_LEFT_CHAIR = MovingObject("the front left chair", ("Mesh010.obj", "Mesh036.obj"), (-1.0, 0.0, 0.0), 0.06)
MOVING_OBJECTS = {
    "living-room": MovingObject("the round table with its bottle and glasses",
                                ("Mesh000.obj", "Mesh031.obj", "Mesh037.obj", "Mesh001.obj", "Mesh002.obj",
                                 "Mesh030.obj", "Mesh044.obj"), (0.0, 0.0, 1.0), 0.04),
    "dining-room": FRONT_LEFT_CHAIR,
    "breakfast-room-open": FRONT_LEFT_CHAIR,
}


def moved(base, motion: str, step: float, frame: int):
    """The sensor's to_world at ``frame``: ``base`` turned or moved in the camera's own frame."""
    import mitsuba as mi

    if motion == "pan":
        return base @ mi.ScalarTransform4f().rotate([0, 1, 0], step * frame)
    if motion == "dolly":
        return base @ mi.ScalarTransform4f().translate([0, 0, step / 100 * frame])
    return base


def turned(value, name: str, degrees: float, pivot: np.ndarray):
    """A light's parameter ``name`` (its value as ``mi.traverse`` holds it) turned by ``degrees`` about the
    vertical through ``pivot``: a transform (``to_world``), points (``vertex_positions``, ``position``) or a
    direction (``sun_direction``, ``direction``), in the parameter's own type, opaque."""
    import drjit as dr
    import mitsuba as mi

    turn = mi.ScalarTransform4f().translate(pivot.tolist()) @ mi.ScalarTransform4f().rotate(UP.tolist(), degrees) \
        @ mi.ScalarTransform4f().translate((-pivot).tolist())
    matrix = np.array(turn.matrix, dtype=np.float64).reshape(4, 4)
    if name == "to_world":
        result = type(value)(mi.ScalarMatrix4f(matrix @ np.array(value.matrix, dtype=np.float64).reshape(4, 4)))
    elif name == "vertex_positions":
        points = np.array(value, dtype=np.float64).reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
        result = type(value)(points.ravel())
    elif name in ("position", "sun_direction", "direction"):  # one point, or one direction that has no place
        vector = matrix[:3, :3] @ np.array(value, dtype=np.float64).reshape(3)
        result = type(value)(*(vector + matrix[:3, 3] if name == "position" else vector).tolist())
    else:
        raise ValueError(f"no way to turn a light's {name}")
    dr.make_opaque(result)
    return result


class NoMotion(Exception):
    """A scene has nothing that a motion moves (no object chosen for it, no one main light)."""


class SceneMotion:
    """A scene as it is at each frame of one motion (:meth:`at`), its parameters set through ``mi.traverse`` and
    made opaque: a literal would be compiled into every kernel that reads it, so each frame would compile them
    all again (a second and more a frame on two cores). Frame 0 is the scene as loaded."""

    def __init__(self, scene, scene_name: str, motion: str, step: float):
        import mitsuba as mi

        self.motion, self.scene, self.parameters = motion, scene, mi.traverse(scene)
        self.frames: dict[str, Callable[[int], object]] = {}  # parameter -> its value at a frame
        if motion in ("pan", "dolly"):
            self._camera(scene, motion, step)
            self.label = f"{motion}{step:g}"
            self.description = f"the camera, {step:g} {'degrees' if motion == 'pan' else 'hundredths'} a frame"
        elif motion == "object":
            if scene_name not in MOVING_OBJECTS:
                raise NoMotion(f"no object of {scene_name} is chosen to move (MOVING_OBJECTS)")
            moving = MOVING_OBJECTS[scene_name]
            self._object(scene, moving)
            self.label = moving.label()
            self.description = f"{moving.name}, {moving.step:g} units a frame along {moving.direction}"
        elif motion == "light":
            self.description = f"{self._light(scene, step)}, {step:g} degrees a frame"
            self.label = f"light{step:g}"
        else:
            self.label, self.description = "still", "nothing"
        self.parameters.keep(list(self.frames))  # an update then schedules these alone, not every parameter

    def at(self, frame: int) -> None:
        """Set the scene as it is at ``frame``."""
        for key, value_at in self.frames.items():
            self.parameters[key] = value_at(frame)
        if self.frames:
            self.parameters.update()

    def _key(self, node, name: str) -> str:
        """The key of ``node``'s parameter ``name``: keys of shapes without ids are made of addresses."""
        for key, (_, _, owner, _) in self.parameters.properties.items():
            if owner is node and key.rsplit(".", 1)[-1] == name:
                return key
        raise KeyError(f"{node.class_name()} has no parameter {name}")

    def _camera(self, scene, motion: str, step: float) -> None:
        import drjit as dr
        import mitsuba as mi

        key = self._key(scene.sensors()[0], "to_world")
        base = mi.ScalarTransform4f(np.array(self.parameters[key].matrix).reshape(4, 4))

        def value_at(frame: int):
            value = mi.AffineTransform4f(moved(base, motion, step, frame))
            dr.make_opaque(value)
            return value
        self.frames[key] = value_at

    def _object(self, scene, moving: MovingObject) -> None:
        import mitsuba as mi

        shapes = [shape for shape in scene.shapes() if _mesh_name(shape) in moving.meshes]
        if len(shapes) != len(moving.meshes):
            raise NoMotion(f"found {len(shapes)} of the meshes of {moving.name}: {', '.join(moving.meshes)}")
        offset = np.asarray(moving.direction) * moving.step
        for shape in shapes:
            key = self._key(shape, "vertex_positions")
            original = np.array(self.parameters[key], dtype=np.float64).reshape(-1, 3)
            # a buffer made from an array is no literal: nothing to make opaque
            self.frames[key] = lambda frame, original=original: mi.Float((original + frame * offset).ravel())
            if shape.has_vertex_normals():
                # set with the positions, a mesh keeps these normals; without them Mitsuba sums new ones with float
                # atomics, in another order each run, and the sequence's bits changed (docs/experiments.md)
                normals = np.array(self.parameters[self._key(shape, "vertex_normals")], dtype=np.float32)
                self.frames[self._key(shape, "vertex_normals")] = lambda frame, normals=normals: mi.Float(normals)

    def _light(self, scene, degrees: float) -> str:
        """Turn the scene's main light (its one emitter other than a constant background); what it is, in words."""
        lights = [e for e in scene.emitters() if e.class_name() != "ConstantBackgroundEmitter"]
        if len(lights) != 1:
            raise NoMotion(f"the light motion turns a scene's one main light; this scene has {len(lights)}")
        light, pivot = lights[0], np.asarray(scene.bbox().center(), dtype=np.float64)
        shape = light.get_shape()
        node = shape if shape is not None else light
        names = [key.rsplit(".", 1)[-1] for key, (_, _, owner, _) in self.parameters.properties.items()
                 if owner is node]
        name = next((n for n in ("sun_direction", "direction", "position", "vertex_positions", "to_world")
                     if n in names), None)
        if name is None:
            raise NoMotion(f"no way to turn {light.class_name()}")
        key = self._key(node, name)
        original = type(self.parameters[key])(self.parameters[key])
        self.frames[key] = lambda frame: turned(original, name, degrees * frame, pivot)
        return f"{light.class_name()}'s {name}" + (f" ({shape.class_name()})" if shape is not None else "")


def _mesh_name(shape) -> str | None:
    """The file an imported mesh was loaded from: Mitsuba keeps it only in the mesh's description."""
    text = str(shape)
    return text.split('name = "', 1)[1].split('"', 1)[0] if 'name = "' in text else None


def reference(loaded_scene, name: str, label: str, frame: int, spp: int, res: int, second: bool = False) -> np.ndarray:
    """The frame's reference (``second``: another, independent of the first), cached under the gmcpt cache by the
    scene, the motion's ``label`` (:class:`SceneMotion`), the frame, size and samples."""
    from gmcpt.seeds import SEQUENCE_REFERENCE_SEEDS as REFERENCE_SEEDS
    from gmcpt.io.files import atomic_output, cache_folder
    from gmcpt.render.kernels import render_native

    tail = "-b" if second else ""
    path = cache_folder("sequence-references") / f"{name}-{label}-{frame:03d}-{res}-{spp}{tail}.npy"
    if path.exists():
        return np.load(path)
    scene, integrator = loaded_scene
    chunk, seed = min(128, spp), REFERENCE_SEEDS[second]
    passes = max(1, spp // chunk)
    total = 0.0
    for index in range(passes):
        total = total + render_native(scene, scene.sensors()[0], integrator, chunk, seed + frame * 97 + index)
    image = (total / passes).reshape(res, res, 3).astype(np.float32)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as temporary, open(temporary, "wb") as handle:  # a stopped run leaves no half a file
        np.save(handle, image)
    return image


class Accumulation:
    """Temporal accumulation + OIDN (see the module's docstring)."""

    def __init__(self):
        self.previous = None

    def render(self, scene, integrator, aov, spp: int, seed: int) -> np.ndarray:
        """The next frame (every stage is charged to it: :func:`gmcpt.evaluation.sequences.take_turns`)."""
        from gmcpt.evaluation.sequences import denoised_with_aov_guides
        from gmcpt.render.kernels import render_native
        from gmcpt.temporal.survey import geometry
        from gmcpt.temporal.history import PastFrame, reproject

        sensor = scene.sensors()[0]
        image = render_native(scene, sensor, integrator, spp, seed)
        positions, normals, projection = geometry(scene, sensor)
        length = np.ones(image.shape[0])
        if self.previous is not None:
            past, past_length = self.previous
            source, valid = reproject(past, positions, normals)
            weight = np.maximum(1 / (past_length[source] + 1), ACCUMULATION_MIN_WEIGHT)
            blended = weight[:, None] * image + (1 - weight[:, None]) * past.total[source]
            image = np.where(valid[:, None], blended, image)
            length = np.where(valid, past_length[source] + 1, 1)
        self.previous = (PastFrame(0, image, length, positions, normals, projection), length)
        return denoised_with_aov_guides(scene, aov, image, spp, seed)


def motion_step(text: str) -> tuple[str, float]:
    """``MOTION=VALUE`` of ``--step``."""
    name, _, value = text.partition("=")
    try:
        if name in DEFAULT_STEPS:
            return name, float(value)
    except ValueError:
        pass
    raise argparse.ArgumentTypeError(f"--step takes MOTION=VALUE with MOTION one of {', '.join(DEFAULT_STEPS)}, "
                                     f"got {text!r}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["living-room"])
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--warm", type=int, default=4, help="frames left out of the means (history builds up)")
    parser.add_argument("--res", type=int, default=128)
    parser.add_argument("--motion", nargs="+", choices=MOTIONS, default=["pan", "dolly", "object", "light"])
    parser.add_argument("--step", type=motion_step, nargs="+", default=[],
                        help="MOTION=VALUE: degrees a frame (pan, light) or hundredths of a unit (dolly); "
                             + ", ".join(f"{k}={v:g}" for k, v in DEFAULT_STEPS.items()) + " unless given")
    parser.add_argument("--budgets", type=float, nargs="+", default=[1, 2, 4])
    parser.add_argument("--path-spp", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32])
    parser.add_argument("--light-spp", type=int, nargs="*", default=[1, 2, 4, 8, 16],
                        help="the lightpath+oidn contender's settings (none: left out)")
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--record", type=Path, help="write the rows and verdicts here (JSON) and a plot beside it")
    parser.add_argument("--merge", type=Path, nargs="+", metavar="PART.json",
                        help="measure nothing: merge records of runs on other scenes into --record (and its plot)")
    parser.add_argument("--references-only", action="store_true",
                        help="measure nothing: render and cache the references alone (untimed, so a busy machine "
                             "may do it), for a later run on a quiet one")
    args = parser.parse_args()
    if args.merge:
        if not args.record:
            parser.error("--merge writes --record: give it")
        merge(args.record, args.merge)
        return 0
    args.step = {**DEFAULT_STEPS, **dict(args.step)}  # the record keeps every motion's pace
    if args.record:
        args.record.parent.mkdir(parents=True, exist_ok=True)  # before the run, not after it

    import gmcpt  # noqa: F401  (variant, LLVM)
    import mitsuba as mi

    from gmcpt.cli.eval import _commit
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.evaluation.sequences import AOV_GUIDES
    from gmcpt.render.scene import path_integrator

    rows, verdicts, moving, started, commit = [], [], {}, time.time(), _commit()  # the commit before docs/ changes
    for eval_scene in [s for s in evaluation_scenes(None, 2) if s.name in args.scenes]:
        aov = mi.load_dict(AOV_GUIDES)  # loading it is no part of a frame
        for motion in args.motion:
            # a scene of its own for each motion, as a user's animation has: after an earlier motion moved its meshes
            # a scene's frozen kernels ran plain (gmcpt.render.kernels.ANIMATED_MOVES), and its light sequence paid
            # for the object's (docs/experiments.md, sixty-fifth session)
            scene = eval_scene.load(args.res)
            integrator = path_integrator(scene)
            try:
                changes = SceneMotion(scene, eval_scene.name, motion, args.step.get(motion, 0.0))
            except NoMotion as reason:
                print(f"skipping {eval_scene.name} {motion}: {reason}", flush=True)
                continue
            if args.references_only:
                start = time.time()
                references(args, eval_scene.name, scene, integrator, changes)
                print(f"{eval_scene.name} {motion}: {args.frames} frames' references ({time.time() - start:.0f} s)",
                      flush=True)
            else:
                found = measure(args, eval_scene.name, scene, integrator, aov, changes)
                rows += found
                verdicts += judge(found, eval_scene.name, motion)
                moving.setdefault(eval_scene.name, {})[motion] = changes.description
    if args.record and not args.references_only:
        record(args, rows, verdicts, moving, time.time() - started, commit)
    return 0


def references(args, name: str, scene, integrator, changes: SceneMotion) -> tuple[list, list, list]:
    """Each frame's two references (rendered once, then read from the cache) and its geometry, the scene left as it
    is at the last frame: (firsts, seconds, geometries)."""
    from gmcpt.evaluation.stability import FrameGeometry
    from gmcpt.temporal.survey import geometry

    sensor = scene.sensors()[0]
    firsts, seconds, geometries = [], [], []
    for frame in range(args.frames):
        changes.at(frame)
        firsts.append(reference((scene, integrator), name, changes.label, frame, args.reference_spp, args.res))
        seconds.append(reference((scene, integrator), name, changes.label, frame, args.reference_spp, args.res,
                                 second=True))
        geometries.append(FrameGeometry(*geometry(scene, sensor)))
    return firsts, seconds, geometries


def measure(args, name: str, scene, integrator, aov, changes: SceneMotion) -> list[dict]:
    """The rows of every contender on one scene in one motion (printed as they come)."""
    from gmcpt.evaluation.sequences import (Run, Truth, light_path_oidn_run, path_oidn_run, sequence_figures,
                                            sequence_run, stage_means, take_turns)

    truth = Truth.of(*references(args, name, scene, integrator, changes), args.warm)

    def accumulation_run(spp):
        accumulation = Accumulation()
        return Run("accumulation+oidn", spp,
                   lambda frame, seed: (accumulation.render(scene, integrator, aov, spp, seed), {}))

    def sequence_runs():
        return [sequence_run(scene, integrator, budget, seed=3) for budget in args.budgets]

    def frame_seed(frame):
        return 1000 + frame

    # the process's memory warmed: throwaway sequences, as the contest then runs them side by side, untimed
    take_turns(sequence_runs(), range(args.frames), changes.at, frame_seed)
    runs = [path_oidn_run(scene, integrator, aov, spp) for spp in args.path_spp] \
        + [light_path_oidn_run(scene, integrator, aov, spp) for spp in args.light_spp] \
        + [accumulation_run(spp) for spp in args.path_spp] + sequence_runs()
    take_turns(runs, range(args.frames), changes.at, frame_seed)
    rows = []
    for run in runs:
        row = {"scene": name, "motion": changes.motion, "contender": run.contender, "rate": 1.0, "spp": run.amount,
               **sequence_figures(run.images, run.seconds, truth),
               "stages": stage_means(run.stages, run.seconds, args.warm)}
        rows.append(row)
        on_changed = "-" if row["psnr_changed"] is None else f"{row['psnr_changed']:6.2f}"
        print(f"{name:20s} {changes.motion:6s} {run.contender:18s} {run.amount:4g}: {row['psnr']:6.2f} dB "
              f"(changed pixels {on_changed} dB, {row['changed_share']:.1%} of them)  FLIP {row['flip']:.4f}  "
              f"{row['seconds']:.3f} s a frame  flicker {row['flicker']:.3f} (in place {row['screen_flicker']:.3f})",
              flush=True)
    return rows


def judge(rows: list[dict], name: str, motion: str) -> list[dict]:
    """The sequence mode's verdicts against each baseline on one scene in one motion (printed)."""
    from gmcpt.evaluation.sequences import sequence_verdict

    verdicts = []
    for baseline in ("path+oidn", "lightpath+oidn", "accumulation+oidn"):
        found = sequence_verdict(rows, baseline)
        if not found:
            continue
        found = {"scene": name, "motion": motion, **found}
        verdicts.append(found)
        gap = "-" if found["changed_gap_db"] is None else f"{found['changed_gap_db']:+.2f} dB"
        print(f"{name} {motion}: sequence vs {baseline}: {found['speedup']:.2f}x at equal time "
              f"({found['bounds']} bounds of {found['settings']}); flicker {found['flicker_ratio']:.2f}x its "
              f"flicker at the sequence's time (in place {found['screen_flicker_ratio']:.2f}x); changed pixels "
              f"{gap} against it at the sequence's time")
    return verdicts


def record(args, rows: list[dict], verdicts: list[dict], moving: dict, seconds: float, commit: str) -> None:
    """``args.record`` (JSON: command, date, settings, what moved, versions, rows, verdicts) and its plot
    (``.png``)."""
    import datetime

    from gmcpt.cli.eval import run_versions, machine_line
    from gmcpt.evaluation.plots import sequence_plot
    from gmcpt.io.exr import atomic_output
    from gmcpt.io.files import json_text

    data = {"command": "python benchmarks/sequence.py " + " ".join(sys.argv[1:]),
            "date": datetime.date.today().isoformat(), "commit": commit, "machine": machine_line(),
            "settings": {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()},
            "moving": moving, "versions": run_versions(), "seconds": seconds, "rows": rows, "verdicts": verdicts}
    with atomic_output(args.record) as temporary:
        Path(temporary).write_text(json_text(data, indent=1))
    sequence_plot(rows, args.record.with_suffix(".png"))
    print(f"wrote {args.record} and {args.record.with_suffix('.png')}")


def merge(target: Path, parts: list[Path]) -> None:
    """One record of several runs (each a ``--record``), on other scenes or other motions of a scene: their rows,
    verdicts and what moved, the commands, commits and dates joined, the seconds summed, the settings of the first
    with every scene; and its plot."""
    import json

    from gmcpt.evaluation.plots import sequence_plot
    from gmcpt.io.exr import atomic_output
    from gmcpt.io.files import json_text

    records = [json.loads(part.read_text()) for part in parts]
    scenes = list(dict.fromkeys(scene for r in records for scene in r["settings"]["scenes"]))
    moving = {}
    for r in records:
        for scene, motions in r["moving"].items():
            moving[scene] = {**moving.get(scene, {}), **motions}
    # each part's commit and date, in the commands' order, where they differ (a part rerun after a change)
    merged = dict(records[0], command=" && ".join(r["command"] for r in records),
                  commit=" && ".join(dict.fromkeys(r["commit"] for r in records)),
                  date=" && ".join(dict.fromkeys(r["date"] for r in records)),
                  seconds=sum(r["seconds"] for r in records),
                  settings=dict(records[0]["settings"], scenes=scenes, record=str(target)),
                  moving=moving,
                  rows=[row for r in records for row in r["rows"]],
                  verdicts=[verdict for r in records for verdict in r["verdicts"]])
    with atomic_output(target) as temporary:
        Path(temporary).write_text(json_text(merged, indent=1))
    sequence_plot(merged["rows"], target.with_suffix(".png"))
    print(f"wrote {target} and {target.with_suffix('.png')} ({len(records)} records)")


if __name__ == "__main__":
    sys.exit(main())
