#!/usr/bin/env python3
"""The budget chooser against its two ways and both baselines, per evaluation scene (256x256, cached references).

For each scene and ``--budgets`` (mean path samples a pixel): the first pass's signal
(:func:`gmcpt.sampling.budget.relative_variance`, :func:`gmcpt.sampling.budget.edge_share`), the default (`gan_oidn`) at
that budget forced sparse and forced dense, what the chooser picks, and path tracing (round(budget) spp) + OIDN and
adaptive path tracing + OIDN at the same budget (baselines at seed + 17, their guides from round(budget) spp, as the
evaluation). Prints PSNR dB per scene, each the mean over ``--seeds``, and the means of the real and synthetic groups.

    python benchmarks/budget_chooser.py [--budgets 3.2 4.8 6.4] [--scenes NAME ...] [--procedural 2] [--seeds 0 1 2]
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


def _cell(value: float | None, width: int) -> str:
    """A signal to 3 decimals, or ``-`` where the frame had no first pass to read it from."""
    return f"{'-':>{width}}" if value is None else f"{value:{width}.3f}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budgets", type=float, nargs="+", default=[3.2, 4.8, 6.4])
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all available)")
    parser.add_argument("--procedural", type=int, default=2, help="held-out procedural scenes")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2],
                        help="each row is the mean over these seeds (one seed's spread is 0.1-0.4 dB a scene)")
    parser.add_argument("--feature-spp", type=int, help="the default's feature pass (default: the product's)")
    parser.add_argument("--baseline-guides", type=int, default=0, metavar="SPP",
                        help="the baselines' OIDN guides from a feature pass of SPP (default 0: their own samples a "
                             "pixel, round(budget), as the evaluation)")
    args = parser.parse_args(argv)

    import gmcpt  # noqa: F401
    import mitsuba as mi
    mi.set_log_level(mi.LogLevel.Error)
    from gmcpt.sampling import budget
    from gmcpt.sampling.adaptive import AdaptiveSettings, render_adaptive
    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.evaluation.baselines import render_full
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.image.metrics import psnr
    from gmcpt.render.kernels import render_features
    from gmcpt.render.scene import path_integrator
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import scene_sensor

    thresholds = budget.DENSE_ABOVE, budget.EDGES_ABOVE

    def default_at(scene, integrator, amount: float, threshold: float, seed: int):
        budget.DENSE_ABOVE = budget.EDGES_ABOVE = threshold
        frame, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(
            budget=amount, seed=seed, **({"feature_spp": args.feature_spp} if args.feature_spp else {})))
        budget.DENSE_ABOVE, budget.EDGES_ABOVE = thresholds
        return frame, complete(frame, DEFAULT_METHOD).image

    rows = []
    print(f"{'scene':<22} {'budget':>6} {'signal':>7} {'edges':>6} " + " ".join(f"{c:>13}" for c in COLUMNS),
          flush=True)
    for eval_scene in evaluation_scenes(args.scenes, args.procedural, print):
        reference = eval_scene.reference(256, 4096)
        scene = eval_scene.load(256)
        integrator = path_integrator(scene)
        for amount in args.budgets:
            runs = []
            for seed in args.seeds:
                sparse_frame, sparse = default_at(scene, integrator, amount, math.inf, seed)
                _, dense = default_at(scene, integrator, amount, -1.0, seed)
                signal, edges = sparse_frame.info.relative_variance, sparse_frame.info.edge_share
                plan = budget.plan_budget(amount, sparse_frame.mask.size)
                chosen = dense if budget.choose(plan, signal or 0.0, edges or 0.0) == budget.DENSE else sparse
                own = max(1, round(amount))
                guides = render_features(scene, scene_sensor(scene), args.baseline_guides or own, seed + 17)
                noisy = render_full(scene, integrator, own, seed + 17)
                path = denoise_oidn(noisy, guides["albedo"], guides["normal"])
                adaptive, _, _ = render_adaptive(scene, integrator, AdaptiveSettings(budget=amount, seed=seed + 17),
                                                 features=guides)
                runs.append([psnr(image, reference) for image in (sparse, dense, chosen, path, adaptive)])
                if plan.dense_only:
                    runs[-1][0] = math.nan  # no first pass, no choice: there is no sparse frame
            values = list(np.mean(runs, axis=0))
            rows.append({"scene": eval_scene.name, "real": getattr(eval_scene, "real", False), "budget": amount,
                         "signal": signal, "psnr": values})
            print(f"{eval_scene.name:<22} {amount:6.1f} {_cell(signal, 7)} {_cell(edges, 6)} "
                  + " ".join(f"{value:13.2f}" for value in values), flush=True)
    for label, real in (("real mean", True), ("synthetic mean", False)):
        for amount in args.budgets:
            group = [row["psnr"] for row in rows if row["real"] == real and row["budget"] == amount]
            if group:
                print(f"{label:<22} {amount:6.1f} {'':>7} {'':>6} " + " ".join(f"{v:13.2f}" for v in np.mean(group, axis=0)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
