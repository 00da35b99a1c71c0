#!/usr/bin/env python3
"""Where the default's error is: traced or filled pixels, against adaptive path tracing + OIDN on the same pixels.

For each evaluation scene (256x256, cached 4096-spp references) at ``rate`` x ``spp`` (default 0.3 x 16 = 4.8
samples a pixel): the default (`gan_oidn`, `two_pass` mask) and adaptive path tracing + OIDN at the same
samples. Prints each one's sRGB MSE over the traced pixels, over the untraced ones, and in all, with the
share of the default's squared error that lies on the untraced pixels, and the PSNR of each.

    python benchmarks/error_split.py [--rate 0.3] [--spp 16] [--scenes NAME ...] [--procedural 2]
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
    parser.add_argument("--rate", type=float, default=0.3)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--scenes", nargs="+", help="evaluation scene names (default: all available)")
    parser.add_argument("--procedural", type=int, default=2, help="held-out procedural scenes")
    args = parser.parse_args(argv)

    import gmcpt  # noqa: F401
    import mitsuba as mi
    mi.set_log_level(mi.LogLevel.Error)
    from gmcpt.sampling.adaptive import AdaptiveSettings, render_adaptive
    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.image.metrics import psnr, tonemap
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import path_integrator

    print(f"{'scene':<22} {'':>8} {'traced MSE':>11} {'untraced MSE':>13} {'all MSE':>9} {'untraced share':>15} "
          f"{'PSNR dB':>8}")
    for eval_scene in evaluation_scenes(args.scenes, args.procedural, print):
        reference = eval_scene.reference(256, 4096)
        scene = eval_scene.load(256)
        integrator = path_integrator(scene)
        frame, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(rate=args.rate, spp=args.spp, seed=17))
        ours = complete(frame, DEFAULT_METHOD).image
        theirs, _, _ = render_adaptive(scene, integrator, AdaptiveSettings(budget=args.rate * args.spp, seed=17))
        traced = frame.mask
        for label, image in ((DEFAULT_METHOD, ours), ("adaptive", theirs)):
            error = ((tonemap(image) - tonemap(reference)) ** 2).mean(axis=-1)
            share = error[~traced].sum() / max(error.sum(), 1e-12)
            print(f"{eval_scene.name:<22} {label:>8} {error[traced].mean():11.2e} {error[~traced].mean():13.2e} "
                  f"{error.mean():9.2e} {share:15.2f} {psnr(image, reference):8.2f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
