#!/usr/bin/env python3
"""The default pipeline's PSNR with two or more GAN weights files, side by side, on the evaluation scenes.

Each evaluation scene (256x256, cached 4096-spp references, as ``gmcpt eval``) is rendered once per rate
(``two_pass`` mask, ``spp`` a traced pixel, seed 17 as ``benchmarks/error_split.py``) and that one frame is
completed with ``gan_oidn`` and each weights file, so the columns differ only in the generator. Prints
per-scene PSNR (tonemapped sRGB), the real and synthetic means and the change of each weights file
against the first.

    python benchmarks/weights_quality.py --weights gan-cpu gan-cpu-real [--rates 0.2 0.3 0.4] [--spp 16]   (after scripts/train_real.sh)
        [--scenes NAME ...] [--procedural 2] [--threads 1]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--weights", nargs="+", default=["gan-cpu"], help="shipped names or .pt files (first: baseline)")
    parser.add_argument("--rates", type=float, nargs="+", default=[0.3])
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all available)")
    parser.add_argument("--procedural", type=int, default=2, help="held-out procedural scenes")
    parser.add_argument("--threads", type=int, default=0, help="Dr.Jit and torch threads (0: all)")
    args = parser.parse_args(argv)

    import gmcpt  # noqa: F401
    import drjit as dr
    import mitsuba as mi
    import torch
    mi.set_log_level(mi.LogLevel.Error)
    if args.threads:
        dr.set_thread_count(args.threads)
        torch.set_num_threads(args.threads)
    from gmcpt.completion import complete
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.gan.weights import load_generator
    from gmcpt.image.metrics import psnr
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import path_integrator

    names = [Path(w).stem for w in args.weights]
    for weights in args.weights:
        load_generator(weights)  # a missing or corrupt file: fail before any rendering
    header = f"{'rate':>5} {'scene':<22} {'group':<9} " + " ".join(f"{n:>14}" for n in names) + \
        "".join(f" {'d ' + n:>16}" for n in names[1:])
    print(header, flush=True)
    scores = {}  # (rate, group) -> list of per-scene rows
    for eval_scene in evaluation_scenes(args.scenes, args.procedural, print):
        reference = eval_scene.reference(256, 4096)
        scene = eval_scene.load(256)
        integrator = path_integrator(scene)
        group = "real" if eval_scene.real else "synthetic"
        for rate in args.rates:
            frame, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(rate=rate, spp=args.spp, seed=17))
            row = [psnr(complete(frame, "gan_oidn", weights=w).image, reference) for w in args.weights]
            scores.setdefault((rate, group), []).append(row)
            print(_line(f"{rate:5.2f} {eval_scene.name:<22} {group:<9}", row), flush=True)
    print()
    for rate in args.rates:
        for group in ("real", "synthetic", "all"):
            rows = [r for (rt, g), rs in scores.items() if rt == rate and group in (g, "all") for r in rs]
            if rows:
                print(_line(f"{rate:5.2f} {'mean of ' + str(len(rows)):<22} {group:<9}", np.mean(rows, axis=0)))
    return 0


def _line(prefix: str, row) -> str:
    return prefix + " " + " ".join(f"{v:14.2f}" for v in row) + "".join(f" {v - row[0]:+16.2f}" for v in row[1:])


if __name__ == "__main__":
    sys.exit(main())
