#!/usr/bin/env python3
"""Adaptive path tracing + OIDN against uniform path tracing + OIDN at equal samples, with alternatives.

For each evaluation scene (256x256, cached 4096-spp references) and each budget (mean path samples a
pixel), uniform path tracing at ``round(budget)`` spp + OIDN beside adaptive path tracing
(:mod:`gmcpt.sampling.adaptive`) at exactly ``budget``, in the shipped form and in the alternatives named by
``--alternatives``; all denoised by OIDN with the same feature pass's albedo and normal. Prints
PSNR dB per scene and the mean of the real and the synthetic scenes.

    python benchmarks/adaptive_baseline.py [--budgets 3.2 4.8 6.4] [--scenes NAME ...] [--procedural 2] [--seeds 0 1]
                                           [--alternatives first1spp first0.4 first0.8 exponent1 cap8]
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: name -> changes to the shipped :class:`gmcpt.sampling.adaptive.AdaptiveSettings`
ALTERNATIVES = {
    "shipped": {},
    "first1spp": {"first_share": 0.0},
    "first0.4": {"first_share": 0.4},
    "first0.8": {"first_share": 0.8},
    "exponent1": {"exponent": 1.0},
    "cap8": {"max_extra": 8},
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", type=float, nargs="+", default=[3.2, 4.8, 6.4])
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all available)")
    parser.add_argument("--procedural", type=int, default=2, help="held-out procedural scenes")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--alternatives", nargs="*", default=[], choices=[a for a in ALTERNATIVES if a != "shipped"])
    args = parser.parse_args(argv)

    import gmcpt  # noqa: F401
    import mitsuba as mi
    mi.set_log_level(mi.LogLevel.Error)
    from gmcpt.sampling import adaptive
    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.evaluation.baselines import render_full
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.image.metrics import psnr
    from gmcpt.render.kernels import render_features
    from gmcpt.render.scene import path_integrator

    scenes = [s for s in evaluation_scenes(args.scenes, args.procedural, print)]
    names = ["path+oidn", "shipped", *args.alternatives]
    results = {}  # (scene, budget, name) -> mean PSNR over seeds
    for eval_scene in scenes:
        reference = eval_scene.reference(256, 4096)
        scene = eval_scene.load(256)
        integrator = path_integrator(scene)
        sensor = scene.sensors()[0]
        features = render_features(scene, sensor, 4)
        for budget in args.budgets:
            scores = {name: [] for name in names}
            for seed in args.seeds:
                noisy = render_full(scene, integrator, max(1, round(budget)), seed + 17)
                scores["path+oidn"].append(psnr(denoise_oidn(noisy, features["albedo"], features["normal"]), reference))
                for name in names[1:]:
                    settings = replace(adaptive.AdaptiveSettings(budget=budget, seed=seed), **ALTERNATIVES[name])
                    image, _, _ = adaptive.render_adaptive(scene, integrator, settings, sensor, features)
                    scores[name].append(psnr(image, reference))
            for name in names:
                results[eval_scene.name, budget, name] = float(np.mean(scores[name]))
            print(f"{eval_scene.name:<22} {budget:>4g} spp  " + "  ".join(
                f"{name} {results[eval_scene.name, budget, name]:6.2f}" for name in names), flush=True)
    for kind in ("real", "synthetic"):
        chosen = [s.name for s in scenes if s.real == (kind == "real")]
        if not chosen:
            continue
        print(f"mean of {len(chosen)} {kind} scenes:")
        for budget in args.budgets:
            print(f"  {budget:>4g} spp  " + "  ".join(
                f"{name} {np.mean([results[s, budget, name] for s in chosen]):6.2f}" for name in names))
    return 0


if __name__ == "__main__":
    sys.exit(main())
