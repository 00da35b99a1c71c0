#!/usr/bin/env python3
"""Completion against Intel OIDN on the same frame, at sizes from 256x256 to 3840x2160, in one run.

For each size the bundled still life is rendered once as the product renders
it (``--rate`` x ``--spp``, the default placement and feature pass) and once at
full frame with ``round(rate * spp)`` spp (OIDN's input: path tracing at the
same samples). Each measurement then runs in a fresh process that reads the
frame from disk: the completion (``--method``, tiled as ``--tile`` says) with
its stages' seconds, and OIDN (albedo and normal guides). Peak memory is the
child's maximum resident set (the frame's buffers included), and in brackets what
the measured call added to what the process held before it.
The table prints completion / OIDN time ratios side by side.

    python benchmarks/completion_vs_oidn.py [--sizes 256x256 1024x1024 1920x1080 3840x2160]
                                            [--method gan_oidn] [--tile 512] [--repeats 3] [--weights NAME]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def render_inputs(scene_path: Path, width: int, height: int, rate: float, spp: int, folder: Path) -> Path:
    """Render the sparse frame and the equal-samples full frame; save both to ``folder/WxH.npz``."""
    import numpy as np

    from gmcpt.frame import PIXEL_BUFFERS
    from gmcpt.io.files import atomic_output
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame
    from gmcpt.render.scene import load_scene, masked_integrator

    scene = load_scene(scene_path, resolution=(width, height))
    integrator = masked_integrator(scene).integrator
    sparse, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(rate=rate, spp=spp, seed=1))
    full, _ = render_sparse_frame(scene, integrator, settings=RenderSettings(rate=1.0, spp=max(1, round(rate * spp)),
                                                                             seed=2))
    path = folder / f"{width}x{height}.npz"
    with atomic_output(path) as temporary, open(temporary, "wb") as handle:
        np.savez(handle, full=full.radiance, spp=sparse.spp, **{name: getattr(sparse, name) for name in PIXEL_BUFFERS})
    return path


def measure(path: str, what: str, method: str, tile: int | None, repeats: int, weights: str | None) -> dict:
    """In this (fresh) process: the median seconds of ``what`` (completion or oidn), its stages and peak memory."""
    import resource
    import statistics

    import numpy as np

    from gmcpt.frame import PIXEL_BUFFERS, SparseFrame

    data = np.load(path)
    frame = SparseFrame(spp=int(data["spp"]), **{name: data[name] for name in PIXEL_BUFFERS})
    if what == "oidn":
        from gmcpt.image.denoise import denoise_oidn
        run = lambda: (denoise_oidn(data["full"], frame.albedo, frame.normal), {})  # noqa: E731
    else:
        from gmcpt.completion import complete, get_method

        options = {"weights": weights} if weights and get_method(method).takes("weights") else {}

        def run():
            result = complete(frame, method, tile=tile, **options)
            return result.image, result.timings
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    seconds, stages = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        _, timings = run()
        seconds.append(time.perf_counter() - start)
        stages.append(timings)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    middle = seconds.index(statistics.median_low(seconds))
    return {"seconds": seconds[middle], "stages": stages[middle], "peak_gb": peak / 2 ** 20,
            "added_gb": (peak - before) / 2 ** 20}


def child(path: Path, what: str, args) -> dict:
    command = [sys.executable, __file__, "--child", str(path), what, "--method", args.method,
               "--repeats", str(args.repeats), "--tile", str(args.tile)] + (["--weights", args.weights] if args.weights else [])
    output = subprocess.run(command, check=True, capture_output=True, text=True).stdout
    return json.loads(output.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=["256x256", "1024x1024", "1920x1080", "3840x2160"])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "still-life" / "scene.xml"))
    parser.add_argument("--rate", type=float, default=0.3)
    parser.add_argument("--spp", type=int, default=4)
    parser.add_argument("--method", help="completion method (default: the product's)")
    parser.add_argument("--tile", type=int, help="completion tile side (0: the whole frame; default: the product's)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--weights", help="generator weights of the GAN methods (default: the shipped default)")
    parser.add_argument("--child", nargs=2, metavar=("FRAME", "WHAT"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    from gmcpt.completion import DEFAULT_METHOD
    from gmcpt.completion.tiles import DEFAULT_TILE

    args.tile = DEFAULT_TILE if args.tile is None else args.tile
    args.method = args.method or DEFAULT_METHOD
    if args.child:
        print(json.dumps(measure(args.child[0], args.child[1], args.method, args.tile, args.repeats, args.weights)))
        return 0

    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for size in args.sizes:
            width, height = map(int, size.lower().split("x"))
            print(f"{size}: rendering", flush=True)
            path = render_inputs(Path(args.scene), width, height, args.rate, args.spp, Path(folder))
            print(f"{size}: completing", flush=True)
            completion = child(path, "completion", args)
            print(f"{size}: OIDN", flush=True)
            oidn = child(path, "oidn", args)
            rows.append((size, completion, oidn))

    print(f"\n{args.method} (tile {args.tile or 'none'}) vs OIDN, {args.rate} x {args.spp} spp, "
          f"median of {args.repeats}; seconds")
    stage_names = sorted({name for _, completion, _ in rows for name in completion["stages"]} - {"completion_s"})
    header = f"{'size':>10}{'completion':>12}{'OIDN':>8}{'ratio':>7}{'peak GB (added)':>17}{'OIDN GB':>9}  stages"
    print(header)
    print("-" * len(header))
    for size, completion, oidn in rows:
        stages = " ".join(f"{name[:-2]} {completion['stages'].get(name, 0.0):.2f}" for name in stage_names)
        print(f"{size:>10}{completion['seconds']:>12.2f}{oidn['seconds']:>8.2f}"
              f"{completion['seconds'] / oidn['seconds']:>7.1f}"
              f"{completion['peak_gb']:>9.2f} ({completion['added_gb']:.2f}){oidn['peak_gb']:>9.2f}  {stages}")
    first, second = rows[0][1]["seconds"], rows[1][1]["seconds"] if len(rows) > 1 else None
    if second:
        print(f"growth {args.sizes[0]} -> {args.sizes[1]}: x{second / first:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
