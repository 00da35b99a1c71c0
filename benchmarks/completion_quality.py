#!/usr/bin/env python3
"""Quality of the completion methods against cached high-spp references.

For each scene and rate, one sparse frame is rendered (256x256, 16 spp,
seeded) and every method completes it; PSNR / SSIM / MSE on tonemapped sRGB
relMSE on linear radiance and FLIP are printed per scene and rate, beside the
noisy full-frame render at the same spp for scale.

    python benchmarks/completion_quality.py [--methods interp nnm pawnnm] [--rates 0.2 0.3 0.4]
        [--scenes cornell-box still-life breakfast-room-open]

Scenes are those of :mod:`gmcpt.evaluation.scenes` (why breakfast-room is evaluated
with its window panes left out is explained there). References come from
gmcpt.evaluation.reference (cached; rendered on a miss, which is slow: run
scripts/make_references.py first). ``--save-frames DIR`` also writes each
sparse frame with its reference as .npz for parameter sweeps.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", nargs="+", default=["interp", "nnm", "pawnnm"])
    parser.add_argument("--rates", type=float, nargs="+", default=[0.2, 0.3, 0.4])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--ref-spp", type=int, default=4096)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scenes", nargs="+", help="names from gmcpt.evaluation.scenes (default: the quality scenes)")
    parser.add_argument("--save-frames", metavar="DIR")
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    import mitsuba as mi
    from gmcpt.completion import complete
    from gmcpt.evaluation.scenes import by_name
    from gmcpt.image.metrics import all_metrics
    from gmcpt.io.files import atomic_output
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    mi.set_log_level(mi.LogLevel.Error)
    rows = []
    try:
        scenes = by_name(args.scenes)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    for eval_scene in scenes:
        if not eval_scene.available():
            print(f"skipping {eval_scene.name}: {eval_scene.path} not found", flush=True)
            continue
        name = eval_scene.name
        reference = eval_scene.reference(args.res, args.ref_spp, progress=lambda m: print(m, flush=True))
        scene = eval_scene.load(args.res)
        nested = getattr(scene.integrator(), "integrator", scene.integrator())
        noisy = np.asarray(mi.render(scene, integrator=nested, spp=args.spp, seed=args.seed + 17))[..., :3]
        rows.append((name, 1.0, f"path {args.spp}spp", all_metrics(noisy, reference), 0.0))
        for rate in args.rates:
            settings = RenderSettings(rate=rate, pattern="random", spp=args.spp, seed=args.seed)
            frame, _ = render_sparse_frame(scene, nested, settings=settings)
            if args.save_frames:
                out = Path(args.save_frames) / f"{name}-r{rate:.2f}.npz"
                out.parent.mkdir(parents=True, exist_ok=True)
                with atomic_output(out) as temporary, open(temporary, "wb") as handle:
                    np.savez_compressed(handle, reference=reference, **{k: getattr(frame, k) for k in (
                        "radiance", "mask", "variance", "albedo", "normal", "depth", "visibility")})
            for method in args.methods:
                start = time.perf_counter()
                result = complete(frame, method)
                rows.append((name, rate, method, all_metrics(result.image, reference),
                             time.perf_counter() - start))
                m = rows[-1][3]
                print(f"  {name} rate {rate:.2f} {method:<12} PSNR {m['psnr']:6.2f}  SSIM {m['ssim']:.4f}  "
                      f"({rows[-1][4]:.2f} s)", flush=True)

    print(f"\n{args.res}x{args.res}, {args.spp} spp per traced pixel, reference {args.ref_spp} spp, seed {args.seed}")
    header = "| scene | rate | method | PSNR dB | SSIM | MSE | relMSE | FLIP | time s |"
    print(header + "\n|---|---|---|---|---|---|---|---|---|")
    for name, rate, method, m, seconds in rows:
        print(f"| {name} | {rate:.2f} | {method} | {m['psnr']:.2f} | {m['ssim']:.4f} | {m['mse']:.2e} | "
              f"{m['relmse']:.2e} | {m['flip']:.4f} | {seconds:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
