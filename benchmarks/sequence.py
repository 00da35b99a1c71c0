#!/usr/bin/env python3
"""Sequences: the sequence mode against per-frame path tracing + OIDN and temporal accumulation + OIDN.

An evaluation scene's camera moves over ``--frames`` frames (``--motion``: ``pan`` turns it about its own up
axis by ``--step`` degrees a frame, ``dolly`` moves it along its view by ``--step`` hundredths of a scene unit,
``still`` keeps it); each frame has two independent references (``--reference-spp`` each, cached; PSNR is read
against their mean). Contenders, each at a ladder of samples a pixel a frame:

- ``path+oidn``: every frame on its own, ``mi.render`` + guides (charged an ``aov`` pass) + OIDN;
- ``accumulation+oidn``: the same samples averaged with the previous frames' accumulated image, reprojected
  to the nearest pixel with the depth and normal tests of :mod:`gmcpt.temporal`, an exponential moving average
  (weight ``max(1 / n, 0.2)`` for the new samples, n the pixel's history length), then OIDN: SVGF's
  accumulation, the strongest simple alternative;
- ``sequence``: :class:`gmcpt.sequence.SequenceRenderer` at the same budget.

The contenders take turns frame by frame, so a machine whose pace drifts slows them alike. Printed: mean
PSNR over the frames after the first ``--warm`` (history needs frames to build), mean warm time
a frame, the flicker figures of :mod:`gmcpt.evaluation.stability` (``flicker``: the error of frame-to-frame
changes along the motion; ``screen_flicker``: in place; both read against the two references, so their noise
is no floor), and the equal-time speed-up of the sequence mode over each baseline
(:func:`gmcpt.evaluation.report.equal_time_verdict`) with its flicker over the baseline's at the same time.

    python benchmarks/sequence.py [--scenes living-room] [--frames 12] [--res 128] [--motion pan]
        [--record docs/sequences.json]

``--record``: the rows, the verdicts and the settings as JSON, a plot beside it (``.png``); ``gmcpt eval --from
docs/results.json`` then puts them in ``docs/results.md``.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ACCUMULATION_MIN_WEIGHT = 0.2


def moved(base, motion: str, step: float, frame: int):
    """The sensor's to_world at ``frame``: ``base`` turned or moved in the camera's own frame."""
    import mitsuba as mi

    if motion == "pan":
        return base @ mi.ScalarTransform4f().rotate([0, 1, 0], step * frame)
    if motion == "dolly":
        return base @ mi.ScalarTransform4f().translate([0, 0, step / 100 * frame])
    return base


#: The two independent references of a frame (sampler seeds): flicker is read against both (see stability).
REFERENCE_SEEDS = (7_000_000, 8_000_000)


def reference(loaded_scene, name: str, motion: str, step: float, frame: int, spp: int, res: int,
              second: bool = False) -> np.ndarray:
    """The frame's reference (``second``: another, independent of the first), cached under the gmcpt cache."""
    from gmcpt.files import cache_folder
    from gmcpt.render import render_native

    tail = "-b" if second else ""
    path = cache_folder("sequence-references") / f"{name}-{motion}{step:g}-{frame:03d}-{res}-{spp}{tail}.npy"
    if path.exists():
        return np.load(path)
    scene, integrator = loaded_scene
    total, chunk, seed = 0.0, 128, REFERENCE_SEEDS[second]
    for index in range(spp // chunk):
        total = total + render_native(scene, scene.sensors()[0], integrator, chunk, seed + frame * 97 + index)
    image = (total / (spp // chunk)).reshape(res, res, 3).astype(np.float32)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.save(path, image)
    return image


class Accumulation:
    """Temporal accumulation + OIDN (see the module's docstring)."""

    def __init__(self):
        self.previous = None

    def render(self, scene, integrator, spp: int, seed: int, aov_seconds) -> tuple[np.ndarray, float]:
        from gmcpt.denoise import denoise_oidn
        from gmcpt.render import _sensor_film_size, render_features, render_native
        from gmcpt.sequence import geometry
        from gmcpt.temporal import PastFrame, reproject

        start = time.perf_counter()
        sensor = scene.sensors()[0]
        height, width = _sensor_film_size(sensor)
        image = render_native(scene, sensor, integrator, spp, seed)
        positions, normals, projection = geometry(scene, sensor)
        length = np.ones(image.shape[0])
        if self.previous is not None:
            past, past_length = self.previous
            source, valid = reproject(past, positions, normals)
            weight = np.maximum(1 / (past_length[source] + 1), ACCUMULATION_MIN_WEIGHT)
            image = np.where(valid[:, None], weight[:, None] * image + (1 - weight[:, None]) * past.total[source], image)
            length = np.where(valid, past_length[source] + 1, 1)
        self.previous = (PastFrame(0, image, length, positions, normals, projection), length)
        guides = render_features(scene, sensor, max(1, spp), seed)
        seconds = time.perf_counter() - start
        start = time.perf_counter()
        denoised = denoise_oidn(image.reshape(height, width, 3).astype(np.float32), guides["albedo"], guides["normal"],
                                max(1, spp))
        return denoised, seconds + time.perf_counter() - start + aov_seconds(spp)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["living-room"])
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--warm", type=int, default=4, help="frames left out of the means (history builds up)")
    parser.add_argument("--res", type=int, default=128)
    parser.add_argument("--motion", choices=["pan", "dolly", "still"], default="pan")
    parser.add_argument("--step", type=float, default=0.5, help="degrees (pan) or hundredths of a unit (dolly)")
    parser.add_argument("--budgets", type=float, nargs="+", default=[1, 2, 4])
    parser.add_argument("--path-spp", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--reference-spp", type=int, default=1024)
    parser.add_argument("--record", type=Path, help="write the rows and verdicts here (JSON) and a plot beside it")
    args = parser.parse_args()

    import gmcpt  # noqa: F401  (variant, LLVM)
    import mitsuba as mi

    from gmcpt.denoise import denoise_oidn
    from gmcpt.evaluation.report import equal_time_verdict
    from gmcpt.evaluation.stability import FrameGeometry, screen_flicker, surface_flicker
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.metrics import all_metrics
    from gmcpt.render import render_features, render_native
    from gmcpt.scene import path_integrator
    from gmcpt.sequence import SequenceRenderer, SequenceSettings, geometry

    from gmcpt.evaluation.cli import _commit

    rows, verdicts, started, commit = [], [], time.time(), _commit()  # the commit before the run rewrites docs/
    for eval_scene in [s for s in evaluation_scenes(None, 2) if s.name in args.scenes]:
        scene = eval_scene.load(args.res)
        integrator = path_integrator(scene)
        sensor = scene.sensors()[0]
        parameters = mi.traverse(sensor)
        base = mi.ScalarTransform4f(np.array(parameters["to_world"].matrix).reshape(4, 4))
        def at(frame: int):
            parameters["to_world"] = moved(base, args.motion, args.step, frame)
            parameters.update()

        aov = mi.load_dict({"type": "aov", "aovs": "a:albedo,n:sh_normal"})  # loading it is no part of a frame

        def aov_seconds(spp: int) -> float:
            start = time.perf_counter()
            np.asarray(mi.render(scene, integrator=aov, spp=max(1, spp)))
            return time.perf_counter() - start

        firsts, seconds, geometries = [], [], []
        for frame in range(args.frames):
            at(frame)
            firsts.append(reference((scene, integrator), eval_scene.name, args.motion, args.step, frame,
                                    args.reference_spp, args.res))
            seconds.append(reference((scene, integrator), eval_scene.name, args.motion, args.step, frame,
                                     args.reference_spp, args.res, second=True))
            geometries.append(FrameGeometry(*geometry(scene, sensor)))
        references = [(a + b) / 2 for a, b in zip(firsts, seconds)]
        contenders = [("path+oidn", spp) for spp in args.path_spp] + [("accumulation+oidn", spp) for spp in args.path_spp] \
            + [("sequence", budget) for budget in args.budgets]
        # frame by frame, every contender in turn: a machine whose pace drifts over minutes slows them alike
        runs = [{"contender": contender, "amount": amount, "accumulation": Accumulation(), "images": [],
                 "sequence": SequenceRenderer(SequenceSettings(budget=amount, seed=3)), "seconds": []}
                for contender, amount in contenders]
        for frame in range(args.frames):
            at(frame)
            seed = 1000 + frame
            for run in runs:
                contender, amount = run["contender"], run["amount"]
                if contender == "path+oidn":
                    start = time.perf_counter()
                    noisy = render_native(scene, sensor, integrator, int(amount), seed)
                    guides = render_features(scene, sensor, int(amount), seed)
                    image = denoise_oidn(noisy.reshape(args.res, args.res, 3).astype(np.float32), guides["albedo"],
                                         guides["normal"], int(amount))
                    spent = time.perf_counter() - start + aov_seconds(int(amount))
                elif contender == "accumulation+oidn":
                    image, spent = run["accumulation"].render(scene, integrator, int(amount), seed, aov_seconds)
                else:
                    start = time.perf_counter()
                    image, _, _ = run["sequence"].render(scene, frame, integrator)
                    spent = time.perf_counter() - start
                run["images"].append(image)
                run["seconds"].append(spent)
        kept = slice(args.warm, None)
        for run in runs:
            images, contender, amount = run["images"], run["contender"], run["amount"]
            metrics = [all_metrics(i, r) for i, r in zip(images[kept], references[kept])]
            psnr = float(np.mean([m["psnr"] for m in metrics]))
            row = {"scene": eval_scene.name, "contender": contender, "rate": 1.0, "spp": amount, "psnr": psnr,
                   "flip": float(np.mean([m["flip"] for m in metrics])),
                   "seconds": float(np.mean(run["seconds"][kept])),
                   "flicker": surface_flicker(images[kept], firsts[kept], geometries[kept], seconds[kept]),
                   "screen_flicker": screen_flicker(images[kept], firsts[kept], seconds[kept])}
            rows.append(row)
            print(f"{eval_scene.name:20s} {contender:18s} {amount:4g}: {psnr:6.2f} dB  FLIP {row['flip']:.4f}  "
                  f"{row['seconds']:.3f} s a frame  "
                  f"flicker {row['flicker']:.3f} (in place {row['screen_flicker']:.3f})", flush=True)
        for baseline in ("path+oidn", "accumulation+oidn"):
            verdict = equal_time_verdict([r for r in rows if r["scene"] == eval_scene.name], "sequence", (baseline,))
            if verdict:
                scene_rows = [r for r in rows if r["scene"] == eval_scene.name]
                flicker_ratio = equal_time_flicker(scene_rows, baseline)
                screen_ratio = equal_time_flicker(scene_rows, baseline, "screen_flicker")
                verdicts.append({"scene": eval_scene.name, "baseline": baseline, "speedup": verdict["speedup"],
                                 "bounds": verdict["bounds"], "settings": verdict["settings"],
                                 "flicker_ratio": flicker_ratio, "screen_flicker_ratio": screen_ratio})
                print(f"{eval_scene.name}: sequence vs {baseline}: {verdict['speedup']:.2f}x at equal time "
                      f"({verdict['bounds']} bounds of {verdict['settings']}); flicker {flicker_ratio:.2f}x its "
                      f"flicker at the sequence's time (in place {screen_ratio:.2f}x)")
    if args.record:
        record(args, rows, verdicts, time.time() - started, commit)
    return 0


def equal_time_flicker(rows: list[dict], baseline: str, figure: str = "flicker") -> float:
    """Geometric mean over the sequence's settings of its ``figure`` over ``baseline``'s at the same seconds a
    frame (interpolated in log time between the baseline's settings, held at its ends)."""
    points = sorted((r["seconds"], r[figure]) for r in rows if r["contender"] == baseline)
    times, values = np.log([p[0] for p in points]), [p[1] for p in points]
    ratios = [r[figure] / np.interp(np.log(r["seconds"]), times, values)
              for r in rows if r["contender"] == "sequence"]
    return float(np.exp(np.mean(np.log(ratios))))


def record(args, rows: list[dict], verdicts: list[dict], seconds: float, commit: str) -> None:
    """``args.record`` (JSON: command, date, settings, versions, rows, verdicts) and its plot (``.png``)."""
    import datetime

    from gmcpt.evaluation.cli import _versions, machine_line
    from gmcpt.evaluation.plots import sequence_plot
    from gmcpt.exr import atomic_output
    from gmcpt.files import json_text

    data = {"command": "python benchmarks/sequence.py " + " ".join(sys.argv[1:]),
            "date": datetime.date.today().isoformat(), "commit": commit, "machine": machine_line(),
            "settings": {key: (str(value) if isinstance(value, Path) else value) for key, value in vars(args).items()},
            "versions": _versions(), "seconds": seconds, "rows": rows, "verdicts": verdicts}
    with atomic_output(args.record) as temporary:
        Path(temporary).write_text(json_text(data, indent=1))
    sequence_plot(rows, args.record.with_suffix(".png"))
    print(f"wrote {args.record} and {args.record.with_suffix('.png')}")


if __name__ == "__main__":
    sys.exit(main())
