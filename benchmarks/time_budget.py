#!/usr/bin/env python3
"""What a time budget (``--time S``) spends, in one warm process: the wall seconds of the whole frame
(``render_and_complete`` with ``RenderSettings(time=S)``: passes, guides, OIDN) over S, and the samples a
pixel it bought. One warm-up frame a scene first (kernels, OIDN's first call), then each S of ``--seconds``
once. The issue's target: every ratio within 0.9-1.1.

    python benchmarks/time_budget.py [--scenes living-room still-life] [--seconds 0.5 1 2 4] [--res 256]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=["living-room", "still-life"],
                        help="evaluation scene names (a missing one is skipped with a line)")
    parser.add_argument("--seconds", type=float, nargs="+", default=[0.5, 1.0, 2.0, 4.0])
    parser.add_argument("--res", type=int, default=256)
    args = parser.parse_args()

    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.pipeline import render_and_complete
    from gmcpt.sampling.strategies import RenderSettings
    from gmcpt.render.scene import load_scene, path_integrator

    print(f"{'scene':22s} {'S':>6s} {'wall s':>8s} {'wall / S':>9s} {'spp':>6s}")
    ratios = []
    for eval_scene in evaluation_scenes(args.scenes, procedural=0, say=print):
        scene = load_scene(str(eval_scene.path), resolution=(args.res, args.res))
        integrator = path_integrator(scene)
        render_and_complete(scene, integrator, RenderSettings(time=args.seconds[0]), "gan_oidn")
        for seconds in args.seconds:
            start = time.perf_counter()
            rendered = render_and_complete(scene, integrator, RenderSettings(time=seconds), "gan_oidn")
            wall = time.perf_counter() - start
            ratios.append(wall / seconds)
            print(f"{eval_scene.name:22s} {seconds:6g} {wall:8.3f} {wall / seconds:9.3f} "
                  f"{rendered.frame.info.budget:6g}")
    if ratios:
        print(f"wall / S from {min(ratios):.3f} to {max(ratios):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
