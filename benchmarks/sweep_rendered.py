#!/usr/bin/env python3
"""PAWNNM settings on rendered frames, scored as the issue scores them.

Frames are ``.npz`` files written by ``completion_quality.py --save-frames DIR``
(a sparse frame with its reference). Each setting changes the shipped default
(:data:`gmcpt.lowrank.DEFAULT` and the low-rank working domain) by the given
fields and is scored by its PSNR (tonemapped sRGB) gain over ``interp`` on
every frame, with the worst frame first, since the target holds at every rate.

    python benchmarks/completion_quality.py --methods interp --save-frames data/frames
    python benchmarks/sweep_rendered.py data/frames/*.npz --try w0=1e4 albedo_eps=0.1 \\
        "search_radius=10 feature_weight=0.3"

A setting is a space-separated list of ``field=value``; ``albedo_eps`` and
``scale`` go to the working domain, everything else to LowRankParams.
"""
from __future__ import annotations

import argparse
import ast
import sys
import time
from dataclasses import fields, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DOMAIN_FIELDS = {"albedo_eps", "albedo_min", "scale"}


def load_frame(path):
    from gmcpt.frame import SparseFrame

    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    reference = arrays.pop("reference")
    arrays["mask"] = arrays["mask"].astype(bool)
    return Path(path).stem, SparseFrame(spp=16, info={}, **arrays), reference


def parse_setting(text: str) -> dict:
    setting = {}
    for item in text.split():
        key, value = item.split("=", 1)
        setting[key] = ast.literal_eval(value)
    return setting


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", nargs="+")
    parser.add_argument("--try", dest="settings", nargs="*", default=[], help="settings to compare with the default")
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    from gmcpt.completion import complete
    from gmcpt.completion.matrix import LOW_RANK_DOMAIN, complete_pawnnm
    from gmcpt.lowrank import DEFAULT
    from gmcpt.image.metrics import psnr

    frames = [load_frame(path) for path in args.frames]
    interp = [psnr(complete(frame, "interp").image, reference) for _, frame, reference in frames]
    print("frames:  " + "  ".join(f"{name} (interp {value:.2f} dB)" for (name, _, _), value in zip(frames, interp)))
    known = {f.name for f in fields(DEFAULT)} | DOMAIN_FIELDS
    rows = []
    for text in ["default"] + args.settings:
        setting = {} if text == "default" else parse_setting(text)
        unknown = set(setting) - known
        if unknown:
            print(f"error: unknown field(s) {', '.join(sorted(unknown))}", file=sys.stderr)
            return 2
        domain = replace(LOW_RANK_DOMAIN, **{k: v for k, v in setting.items() if k in DOMAIN_FIELDS})
        params = replace(DEFAULT, **{k: v for k, v in setting.items() if k not in DOMAIN_FIELDS})
        start = time.perf_counter()
        gains = [psnr(complete_pawnnm(frame, params=params, domain=domain).image, reference) - base
                 for (_, frame, reference), base in zip(frames, interp)]
        rows.append((text, gains, (time.perf_counter() - start) / len(frames)))
        print(f"{text:<40} min {min(gains):+.2f}  mean {np.mean(gains):+.2f}  "
              + " ".join(f"{g:+.2f}" for g in gains) + f"  {rows[-1][2]:.2f} s/frame", flush=True)
    print("\nranked by the worst frame's gain over interp (dB):")
    for text, gains, seconds in sorted(rows, key=lambda row: -min(row[1])):
        print(f"  {min(gains):+.2f}  {text}  ({seconds:.2f} s/frame)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
