#!/usr/bin/env python3
"""What OIDN's large model with 16-ray guides buys each scene, beside a reading of it that needs no reference.

For each evaluation scene with a cached reference, each budget B (4 and 8 by default) and each seed, the frame's
samples are traced as two quarters A1, A2 (B/4 spp each) and a half N (B/2 spp), each with a seed of its own.
The half A = (A1 + A2) / 2 is denoised with guides of B rays (``ds``: what a dense frame does today) and with
16-ray guides taken as clean, which runs OIDN's large model (``dc``); the quarter A1 with guides of B rays
(``d1``). Printed, as means over the seeds:

- ``proxy``: (RMS(dc - ds) / RMS(d1 - ds))^2 of the tonemapped images, how far the large model moves the half
  against how far doubling its samples moves it. It needs no reference, so a product could read it.
- ``doublings``: the large model's true gain at the half budget in doublings of samples (its dB over the dB the
  doubling from B/4 to B/2 gains): above log2(1 + extra seconds / path tracing seconds) the large model pays.
- ``dB at B``: its gain on the whole frame (A + N at B spp, both guide sets).

``--full`` runs the evaluation's 1920x1080 scene instead (its cached reference, ``make eval`` renders it).
docs/experiments.md ("The veach lamp is a tie; better guides pay at 1920x1080 ...") has the figures.

    python benchmarks/denoiser_gain.py [--budgets 4 8] [--seeds 3] [--scenes NAME ...] [--full]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

CLEAN_RAYS = 16


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", type=int, nargs="+", default=[4, 8], help="multiples of 4")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all)")
    parser.add_argument("--procedural", type=int, default=2)
    parser.add_argument("--full", action="store_true", help="the evaluation's 1920x1080 scene instead")
    args = parser.parse_args()
    if any(budget < 4 or budget % 4 for budget in args.budgets):
        parser.error("each budget must be a multiple of 4 (two quarters and a half of whole samples)")

    import gmcpt  # noqa: F401  (finds LLVM)
    import numpy as np

    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.evaluation.config import QUICK
    from gmcpt.evaluation.measure import FULL_REFERENCES
    from gmcpt.evaluation.reference import cached_only, render_reference
    from gmcpt.evaluation.scenes import by_name, evaluation_scenes
    from gmcpt.sampling.budget import denoiser_proxy
    from gmcpt.image.metrics import psnr
    from gmcpt.render.kernels import render_features, render_native
    from gmcpt.render.scene import path_integrator

    def reference_of(eval_scene):
        with cached_only():
            if args.full:
                return render_reference(eval_scene.path, QUICK.full_size, QUICK.full_reference_spp, pass_spp=32,
                                        without=eval_scene.without, folder=FULL_REFERENCES)
            return eval_scene.reference(QUICK.resolution, QUICK.reference_spp)

    scenes = by_name([QUICK.full_scene]) if args.full else evaluation_scenes(args.scenes, args.procedural, say=print)
    print(f"{'scene':<20} {'budget':>6} {'proxy':>6} {'doublings':>9} {'dB at B':>8}  (means of {args.seeds} seeds)")
    for eval_scene in scenes:
        try:
            reference = reference_of(eval_scene)
        except LookupError:
            print(f"{eval_scene.name:<20} no cached reference: make eval renders it")
            continue
        height, width = reference.shape[:2]
        scene = eval_scene.load((width, height) if args.full else QUICK.resolution)
        integrator, sensor = path_integrator(scene), scene.sensors()[0]

        def trace(spp: int, seed: int):
            return render_native(scene, sensor, integrator, spp, seed).reshape(height, width, 3)

        def denoised(image, guides: dict, rays: int):
            return denoise_oidn(image, guides["albedo"], guides["normal"], rays)

        for budget in args.budgets:
            readings = []
            for seed in range(0, 1000 * args.seeds, 1000):
                quarter = budget // 4
                first, second, other = trace(quarter, seed), trace(quarter, seed + 5), trace(2 * quarter, seed + 7)
                half = (first + second) / 2
                guides = render_features(scene, sensor, budget, seed + 17)
                clean = render_features(scene, sensor, CLEAN_RAYS, seed + 17)
                d1, ds = denoised(first, guides, budget), denoised(half, guides, budget)
                dc = denoised(half, clean, CLEAN_RAYS)
                whole = (half + other) / 2
                gain_at_budget = (psnr(denoised(whole, clean, CLEAN_RAYS), reference)
                                  - psnr(denoised(whole, guides, budget), reference))
                doublings = (psnr(dc, reference) - psnr(ds, reference)) / (psnr(ds, reference) - psnr(d1, reference))
                readings.append((denoiser_proxy(d1, ds, dc), doublings, gain_at_budget))
            proxy, doublings, gain = np.mean(readings, axis=0)
            print(f"{eval_scene.name:<20} {budget:>6} {proxy:>6.2f} {doublings:>9.2f} {gain:>+8.2f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
