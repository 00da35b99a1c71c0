#!/usr/bin/env python3
"""The budget chooser against its two ways and both baselines, per evaluation scene (256x256, cached references).

For each scene and ``--budgets`` (mean path samples a pixel): the first pass's signal
(:func:`gmcpt.budget.relative_variance`), the default (`gan_oidn`) at that budget forced sparse and forced dense,
what the chooser picks, and path tracing (round(budget) spp) + OIDN and adaptive path tracing + OIDN at the same
budget. Prints PSNR dB per scene and the means of the real and synthetic groups.

    python benchmarks/budget_chooser.py [--budgets 3.2 4.8 6.4] [--scenes NAME ...] [--procedural 2] [--seed 0]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

COLUMNS = ("sparse", "dense", "chosen", "path+OIDN", "adaptive+OIDN")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", type=float, nargs="+", default=[3.2, 4.8, 6.4])
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all available)")
    parser.add_argument("--procedural", type=int, default=2, help="held-out procedural scenes")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    import gmcpt  # noqa: F401
    import mitsuba as mi
    mi.set_log_level(mi.LogLevel.Error)
    from gmcpt import budget
    from gmcpt.adaptive import AdaptiveSettings, render_adaptive
    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.denoise import denoise_oidn
    from gmcpt.evaluation.baselines import render_full
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.metrics import psnr
    from gmcpt.render import RenderSettings, render_sparse_frame

    def default_at(scene, integrator, amount: float, threshold: float):
        budget.DENSE_ABOVE = threshold
        frame, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(budget=amount, seed=args.seed))
        return frame, complete(frame, DEFAULT_METHOD).image

    rows = []
    print(f"{'scene':<22} {'budget':>6} {'signal':>7} " + " ".join(f"{c:>13}" for c in COLUMNS), flush=True)
    for eval_scene in evaluation_scenes(args.scenes, args.procedural, print):
        reference = eval_scene.reference(256, 4096)
        scene = eval_scene.load(256)
        integrator = scene.integrator()
        integrator = getattr(integrator, "integrator", integrator)
        chosen_threshold = budget.DENSE_ABOVE
        for amount in args.budgets:
            sparse_frame, sparse = default_at(scene, integrator, amount, math.inf)
            dense_frame, dense = default_at(scene, integrator, amount, -1.0)
            chosen = dense if budget.DENSE_ABOVE and sparse_frame.info["relative_variance"] > chosen_threshold \
                and dense_frame.info["budget_choice"] == budget.DENSE else sparse
            budget.DENSE_ABOVE = chosen_threshold
            features = sparse_frame
            noisy = render_full(scene, integrator, max(1, round(amount)), args.seed)
            path = denoise_oidn(noisy, features.albedo, features.normal)
            adaptive, _, _ = render_adaptive(scene, integrator, AdaptiveSettings(budget=amount, seed=args.seed + 17))
            values = [psnr(image, reference) for image in (sparse, dense, chosen, path, adaptive)]
            rows.append({"scene": eval_scene.name, "real": getattr(eval_scene, "real", False), "budget": amount,
                         "signal": sparse_frame.info["relative_variance"], "psnr": values})
            print(f"{eval_scene.name:<22} {amount:6.1f} {rows[-1]['signal']:7.3f} "
                  + " ".join(f"{value:13.2f}" for value in values), flush=True)
    for label, real in (("real mean", True), ("synthetic mean", False)):
        for amount in args.budgets:
            group = [row["psnr"] for row in rows if row["real"] == real and row["budget"] == amount]
            if group:
                print(f"{label:<22} {amount:6.1f} {'':>7} " + " ".join(f"{v:13.2f}" for v in np.mean(group, axis=0)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
