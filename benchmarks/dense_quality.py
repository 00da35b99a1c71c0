#!/usr/bin/env python3
"""A budget's dense frame against Mitsuba's own render at the same samples, both + OIDN with the same guides.

For each evaluation scene with a cached reference (``make eval`` renders them), each budget and each seed: the
product's frame forced dense (``render_sparse_frame`` with the chooser's thresholds at -1) completed by
``gan_oidn`` (OIDN with the frame's guides), and ``mi.render`` at ``round(budget)`` spp denoised by OIDN with
the very same guides. Both draw the same seed (common random numbers: one seed's spread of 0.1-0.4 dB a scene
would hide a 0.1 dB difference), so at an integral budget the two are one render and differ by nothing. At a
budget between two whole numbers (4.8) ``mi.render`` cannot spend the same samples: it is run at both
neighbours (4 and 5 spp) and its PSNR at the budget read between them in log samples (the line OIDN's PSNR
follows over a step of one sample), so the comparison is at equal samples; ``round(budget)`` spp, 4% more
samples at 4.8, is printed beside it. The table gives the PSNR of each, averaged over the seeds, and the
difference at equal samples.

    python benchmarks/dense_quality.py [--budgets 4.8 16] [--seeds 3] [--scenes NAME ...]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", type=float, nargs="+", default=[4.8, 16.0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: the quality scenes)")
    parser.add_argument("--procedural", type=int, default=2)
    args = parser.parse_args()

    import math

    import gmcpt  # noqa: F401  (finds LLVM)
    import numpy as np

    from gmcpt.sampling import budget
    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.evaluation.baselines import render_full
    from gmcpt.evaluation.config import QUICK
    from gmcpt.evaluation.reference import cached_only
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.image.metrics import psnr
    from gmcpt.render.scene import path_integrator
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    budget.DENSE_ABOVE = budget.EDGES_ABOVE = -1.0  # every frame dense
    print(f"{'scene':<20} {'budget':>6} {'dense frame':>11} {'mi.render':>9} {'at round(B)':>11} {'difference':>10}"
          f"  (PSNR dB, means of {args.seeds} seeds; mi.render at the budget's samples, and at round(budget) spp)")
    differences = []
    for eval_scene in evaluation_scenes(args.scenes, args.procedural, say=print):
        with cached_only():
            try:
                reference = eval_scene.reference(QUICK.resolution, QUICK.reference_spp)
            except LookupError:
                print(f"{eval_scene.name:<20} no cached reference: make eval renders it")
                continue
        scene = eval_scene.load(QUICK.resolution)
        integrator = path_integrator(scene)
        for samples in args.budgets:
            neighbours = sorted({max(1, math.floor(samples)), max(1, math.ceil(samples))})
            ours, theirs = [], {spp: [] for spp in neighbours}
            for seed in range(args.seeds):
                frame, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(budget=samples, seed=seed))
                ours.append(psnr(complete(frame, DEFAULT_METHOD).image, reference))
                for spp in neighbours:
                    noisy = render_full(scene, integrator, spp, seed)
                    theirs[spp].append(psnr(denoise_oidn(noisy, frame.albedo, frame.normal, frame.info.feature_spp),
                                            reference))  # the same guides, told as many rays
            means = [float(np.mean(theirs[spp])) for spp in neighbours]
            equal = float(np.interp(math.log(max(samples, 1)), [math.log(spp) for spp in neighbours], means))
            rounded = means[neighbours.index(max(1, round(samples)))]
            difference = float(np.mean(ours)) - equal
            differences.append(difference)
            print(f"{eval_scene.name:<20} {samples:6g} {np.mean(ours):11.2f} {equal:9.2f} {rounded:11.2f} "
                  f"{difference:+10.2f}", flush=True)
    if differences:
        print(f"largest shortfall {min(differences):+.2f} dB, mean {np.mean(differences):+.2f} dB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
