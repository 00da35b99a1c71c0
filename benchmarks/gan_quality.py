#!/usr/bin/env python3
"""Issue 4's evaluation: gan / gan_pawnnm against interp / pawnnm on held-out and bundled scenes.

Scenes: the held-out procedural test split of the dataset (``--dataset``,
seeds 2000000.., references stored in the split at 256x256 / 4096 spp, scenes
rebuilt from their seed and exposure) and the quality scenes of
:mod:`gmcpt.evaluation.scenes` (bundled ones, breakfast-room with its window panes
left out; references from :mod:`gmcpt.evaluation.reference`'s cache). For each scene and rate one sparse frame is rendered (16 spp, seed 0,
``random`` mask) and every method completes it; beside them, full-frame path
tracing with the same number of path samples (``round(rate * spp)`` per
pixel), denoised with Intel Open Image Denoise (``pyoidn``).
Metrics: PSNR, SSIM and MSE on tonemapped sRGB (:mod:`gmcpt.image.metrics`).

    python benchmarks/gan_quality.py [--methods interp gan pawnnm gan_pawnnm] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def scenes(args):
    """(name, scene, nested integrator, reference) for every scene to evaluate."""
    from gmcpt.dataset import list_examples, load_example
    from gmcpt.dataset.scenes import build_scene
    from gmcpt.evaluation.scenes import QUALITY_SCENES

    for path in list_examples(args.dataset, "test")[:args.test_scenes] if args.test_scenes else []:
        example = load_example(path)
        meta = example["meta"]
        scene = build_scene(meta["seed"], meta["resolution"], meta["exposure"], args.spp)
        yield f"proc-{meta['seed']}", scene, scene.integrator(), example["reference"]
    for eval_scene in (QUALITY_SCENES if args.bundled else []):
        if not eval_scene.available():
            print(f"skipping {eval_scene.name}: {eval_scene.path} not found", file=sys.stderr)
            continue
        reference = eval_scene.reference(args.res, args.ref_spp, progress=lambda m: print(m, file=sys.stderr))
        scene = eval_scene.load(args.res)
        yield eval_scene.name, scene, getattr(scene.integrator(), "integrator", scene.integrator()), reference


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["interp", "gan", "pawnnm", "gan_pawnnm"])
    parser.add_argument("--rates", type=float, nargs="+", default=[0.2, 0.3, 0.4])
    parser.add_argument("--dataset", default=str(ROOT / "data" / "procedural"))
    parser.add_argument("--test-scenes", type=int, default=10, help="procedural test scenes (0: none)")
    parser.add_argument("--no-bundled", dest="bundled", action="store_false")
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--weights", help="GAN weights (default: the shipped gan-cpu)")
    parser.add_argument("--json", help="write all rows here")
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    import mitsuba as mi
    from gmcpt.completion import complete
    from gmcpt.image.denoise import denoise_oidn
    from gmcpt.image.metrics import all_metrics
    from gmcpt.render.kernels import render_features
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    mi.set_log_level(mi.LogLevel.Error)
    rows = []

    def add(name, rate, method, image, reference, seconds):
        metrics = all_metrics(image, reference)
        rows.append({"scene": name, "rate": rate, "method": method, "seconds": round(seconds, 3), **metrics})
        print(f"  {name:<16} rate {rate:.2f} {method:<14} PSNR {metrics['psnr']:6.2f}  SSIM {metrics['ssim']:.4f}  "
              f"MSE {metrics['mse']:.2e}  ({seconds:.2f} s)", file=sys.stderr, flush=True)

    for name, scene, integrator, reference in scenes(args):
        features = render_features(scene, scene.sensors()[0])
        for rate in args.rates:
            settings = RenderSettings(rate=rate, pattern="random", spp=args.spp, seed=args.seed)
            frame, _ = render_sparse_frame(scene, integrator, settings=settings)
            for method in args.methods:
                options = {"weights": args.weights} if method.startswith("gan") and args.weights else {}
                start = time.perf_counter()
                result = complete(frame, method, **options)
                add(name, rate, method, result.image, reference, time.perf_counter() - start)
            samples = max(1, round(rate * args.spp))
            noisy = np.asarray(mi.render(scene, integrator=integrator, spp=samples, seed=args.seed + 17))[..., :3]
            add(name, rate, f"path {samples}spp", noisy, reference, 0.0)
            denoised = denoise_oidn(noisy.astype(np.float32), features["albedo"], features["normal"])
            add(name, rate, f"path {samples}spp+oidn", denoised, reference, 0.0)

    methods = list(dict.fromkeys(r["method"] if not r["method"].startswith("path") else "path" + r["method"][r["method"].find("spp") + 3:]
                                 for r in rows))
    key = lambda r: r["method"] if not r["method"].startswith("path") else "path" + r["method"][r["method"].find("spp") + 3:]  # noqa: E731
    print(f"\n{args.res}x{args.res}, {args.spp} spp per traced pixel, seed {args.seed}; PSNR dB / SSIM / MSE (tonemapped sRGB)")
    print("| scene | rate | " + " | ".join(methods) + " |")
    print("|---|---|" + "---|" * len(methods))
    names = list(dict.fromkeys(r["scene"] for r in rows))
    for name in names + ["mean"]:
        for rate in args.rates:
            cells = []
            for method in methods:
                chosen = [r for r in rows if key(r) == method and r["rate"] == rate and (name == "mean" or r["scene"] == name)]
                if not chosen:
                    cells.append("-")
                    continue
                cells.append(f"{np.mean([r['psnr'] for r in chosen]):.2f} / {np.mean([r['ssim'] for r in chosen]):.3f}"
                             f" / {np.mean([r['mse'] for r in chosen]):.1e}")
            print(f"| {name} | {rate:.1f} | " + " | ".join(cells) + " |")
    if args.json:
        Path(args.json).write_text(json.dumps({"settings": vars(args), "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
