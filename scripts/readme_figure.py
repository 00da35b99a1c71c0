#!/usr/bin/env python3
"""Make the README picture: a sparse input beside its completion.

    python scripts/readme_figure.py [--scene scenes/still-life/scene.xml] [--method NAME]

Writes docs/images/<scene>-<method>.png: sparse input (30% of pixels, 16 spp)
on the left, the completed image on the right.
"""
import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "still-life" / "scene.xml"))
    parser.add_argument("--method", help="completion method (default: the product's)")
    parser.add_argument("--rate", type=float, default=0.3)
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    from gmcpt.completion import DEFAULT_METHOD, complete
    from gmcpt.io.exr import write_png
    from gmcpt.sampling.strategies import render_sparse_frame
    from gmcpt.render.scene import load_scene, masked_integrator

    args.method = args.method or DEFAULT_METHOD
    scene = load_scene(args.scene)
    integrator = masked_integrator(scene, rate=args.rate)
    frame, _ = render_sparse_frame(scene, integrator.integrator, settings=integrator.settings())
    completed = complete(frame, args.method).image
    gap = np.ones((frame.shape[0], 4, 3), np.float32)
    side_by_side = np.concatenate([frame.radiance, gap, completed], axis=1)
    out = ROOT / "docs" / "images" / f"{Path(args.scene).parent.name}-{args.method}.png"
    write_png(out, side_by_side)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
