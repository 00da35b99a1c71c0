#!/usr/bin/env python3
"""Sample placement at equal samples: completion with each mask against path tracing + OIDN.

For each evaluation scene one full-frame 16-spp render (the product's masked
render at rate 1, seed 0) is made once; a mask at any rate is then the same
render's pixels where the mask is set (a traced pixel's value has the same
distribution whichever mask picked it), so each placement costs only its
completion. ``two_pass`` reads the first pass's pixels from the same render.
Beside them, path tracing at ``round(rate * spp)`` samples per pixel, full
frame, denoised by OIDN with the feature pass's albedo and normal.

``--predictors`` also tells which cheap signal predicts where completion errs:
with a random mask at rate 0.3, the rank correlation over 8x8 tiles between the
completion's squared error on untraced pixels and each candidate.

    python benchmarks/mask_placement.py [--rates 0.2 0.3 0.4] [--masks random adaptive two_pass]
                                        [--methods gan_oidn gan_pawnnm] [--seeds 0 1 2 3] [--predictors]
                                        [--feature-spp 4]
                                        [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def simulated_mask(full, pattern: str, rate: float, seed: int) -> np.ndarray:
    """The mask the renderer would draw for ``pattern``, its passes read from the full render ``full``."""
    from gmcpt.sampling.masks import (FEATURE_PATTERNS, make_mask, mask_rng, sample_by_density, sample_count,
                                      second_pass_mask)
    from gmcpt.sampling.placement import FIRST_PASS_SHARE, error_density, feature_density

    height, width = full.shape
    if pattern not in FEATURE_PATTERNS:
        return make_mask(height, width, rate, pattern, seed)
    density = feature_density(full.albedo, full.normal, full.depth, full.visibility, full.coverage)
    if pattern == "adaptive":
        return make_mask(height, width, rate, pattern, seed, density)
    count = sample_count(rate, height * width)
    first = sample_by_density(density, max(1, round(count * FIRST_PASS_SHARE)), mask_rng(seed))
    radiance = np.where(first[..., None], full.radiance, 0.0)
    errors = error_density(radiance, np.where(first, full.variance, 0.0), first, full.albedo, full.coverage,
                           density)
    return first | second_pass_mask(errors, count - int(first.sum()), first, seed)


def masked(full, mask: np.ndarray):
    return replace(full, mask=mask, radiance=np.where(mask[..., None], full.radiance, 0.0).astype(np.float32),
                   variance=np.where(mask, full.variance, 0.0).astype(np.float32))


def tile_mean(values: np.ndarray, tile: int = 8) -> np.ndarray:
    h, w = (values.shape[0] // tile) * tile, (values.shape[1] // tile) * tile
    return values[:h, :w].reshape(h // tile, tile, w // tile, tile).mean(axis=(1, 3)).ravel()


def predictors(full, reference, method: str, seed: int, say) -> dict:
    """Rank correlation over 8x8 tiles between the completion's error and each cheap signal."""
    from scipy.stats import spearmanr

    from gmcpt.completion import complete
    from gmcpt.image.domain import WorkingDomain
    from gmcpt.image.metrics import tonemap
    from gmcpt.sampling.placement import error_density, feature_density, feature_edges

    frame = masked(full, simulated_mask(full, "random", 0.3, seed))
    image = complete(frame, method).image
    error = np.where(frame.mask, 0.0, np.mean((tonemap(image) - tonemap(reference)) ** 2, axis=-1))
    density = feature_density(full.albedo, full.normal, full.depth, full.visibility, full.coverage)
    candidates = {
        "feature edges": feature_edges(full.albedo, full.normal, full.depth, full.visibility),
        "no diffuse albedo": 1.0 - full.coverage,
        "sample variance (working domain)": WorkingDomain().variance(
            frame.radiance, frame.variance, WorkingDomain().factor(full.albedo, full.coverage)),
        "neighbour disagreement": error_density(frame.radiance, frame.variance, frame.mask, full.albedo,
                                                full.coverage, np.zeros_like(density), floor=0.0),
        "two_pass density": error_density(frame.radiance, frame.variance, frame.mask, full.albedo,
                                          full.coverage, density),
    }
    rows = {}
    for name, signal in candidates.items():
        rows[name] = float(spearmanr(tile_mean(signal), tile_mean(error)).statistic)
        say(f"    {name:<34} rank correlation {rows[name]:+.3f}")
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", help="names (default: the quality scenes and 2 procedural)")
    parser.add_argument("--rates", type=float, nargs="+", default=[0.2, 0.3, 0.4])
    parser.add_argument("--masks", nargs="+", default=["random", "stratified", "adaptive", "two_pass"])
    parser.add_argument("--methods", nargs="+", help="completion methods (default: the product's)")
    parser.add_argument("--weights", help="generator weights of the gan methods (default: the shipped)")
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--feature-spp", type=int, help="feature pass samples per pixel, for the completion and "
                        "OIDN's guides (default: the product's)")
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--seeds", "--seed", type=int, nargs="+", default=[0],
                        help="seeds, each with frames of its own; the table is the mean over scenes and seeds "
                             "(single frames move the mean by about 0.15 dB)")
    parser.add_argument("--predictors", action="store_true")
    parser.add_argument("--json")
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    import mitsuba as mi

    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.render.scene import path_integrator
    from gmcpt.evaluation.scenes import QUALITY_SCENES, procedural_scenes
    from gmcpt.evaluation.baselines import render_full
    from gmcpt.image.metrics import all_metrics
    from gmcpt.render.kernels import DEFAULT_FEATURE_SPP
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    mi.set_log_level(mi.LogLevel.Error)
    args.methods = args.methods or [DEFAULT_METHOD]
    say = lambda message: print(message, file=sys.stderr, flush=True)  # noqa: E731
    scenes = [s for s in QUALITY_SCENES if s.available()] + procedural_scenes(2)
    if args.scenes:
        scenes = [s for s in scenes if s.name in args.scenes]
    options = {"weights": args.weights} if args.weights else {}
    rows, correlations = [], {}
    for eval_scene in scenes:
        reference = eval_scene.reference(args.res, 4096, progress=say)
        scene = eval_scene.load(args.res)
        integrator = path_integrator(scene)
        for seed in args.seeds:
            full, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(
                rate=1.0, spp=args.spp, seed=seed, feature_spp=args.feature_spp or DEFAULT_FEATURE_SPP))
            if args.predictors and seed == args.seeds[0]:
                say(f"  {eval_scene.name}: what predicts the error of {args.methods[0]}")
                correlations[eval_scene.name] = predictors(full, reference, args.methods[0], seed, say)
            for rate in args.rates:
                samples = max(1, round(rate * args.spp))
                noisy = render_full(scene, integrator, samples, seed + 17)
                denoised = denoise_oidn(noisy, full.albedo, full.normal)
                rows.append({"scene": eval_scene.name, "seed": seed, "rate": rate, "mask": "-",
                             "method": "path + OIDN", "spp": samples, **all_metrics(denoised, reference)})
                say(f"  {eval_scene.name:<20} seed {seed} rate {rate:.2f} {f'path {samples} spp + OIDN':<28} "
                    f"PSNR {rows[-1]['psnr']:6.2f}")
                for pattern in args.masks:
                    start = time.perf_counter()
                    frame = masked(full, simulated_mask(full, pattern, rate, seed))
                    mask_s = time.perf_counter() - start
                    for method in args.methods:
                        image = complete(frame, method, **(options if method.startswith("gan") else {})).image
                        rows.append({"scene": eval_scene.name, "seed": seed, "rate": rate, "mask": pattern,
                                     "method": method, "mask_s": mask_s, **all_metrics(image, reference)})
                        say(f"  {eval_scene.name:<20} seed {seed} rate {rate:.2f} {pattern + ' ' + method:<28} "
                            f"PSNR {rows[-1]['psnr']:6.2f}  (mask {mask_s * 1000:.0f} ms)")
    print(f"\nmean PSNR over scenes{' and seeds ' + str(args.seeds) if len(args.seeds) > 1 else ''} (dB):")
    keys = sorted({(row["mask"], row["method"]) for row in rows}, key=lambda k: (k[0] != "-", k))
    print(f"{'placement':<36}" + "".join(f"{rate:>8.2f}" for rate in args.rates))
    for mask, method in keys:
        means = [np.mean([r["psnr"] for r in rows if r["rate"] == rate and r["mask"] == mask
                          and r["method"] == method]) for rate in args.rates]
        label = "path round(rate x spp) + OIDN" if mask == "-" else f"{method} / {mask}"
        print(f"{label:<36}" + "".join(f"{m:>8.2f}" for m in means))
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "predictors": correlations}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
