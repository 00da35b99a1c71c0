#!/usr/bin/env python3
"""GAN pre-completion time for one frame (target: <= 0.5 s for 256x256 on 2 CPU cores).

Times the whole ``gan`` completion call (working-domain transform, input
assembly, padding, the generator, the inverse transform) on a synthetic
256x256 sparse frame at ``--rate`` (default 0.2, the slowest of the evaluation
rates for a generator that starts from the feature-guided fill, whose window
grows as the rate falls; the content does not matter),
for each torch thread count, ``--repeats`` calls after one warm-up call;
loading the weights happens once and is reported on its own.

    python benchmarks/gan_inference.py [--res 256] [--rate 0.2] [--threads 1 2] [--repeats 10] [--weights gan-cpu]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def synthetic_frame(size: int, rate: float = 0.2):
    import numpy as np

    from gmcpt.frame import SparseFrame
    from gmcpt.sampling.masks import make_mask

    rng = np.random.default_rng(0)
    mask = make_mask(size, size, rate, "random", 0)
    rand = lambda *shape: rng.random((size, size, *shape)).astype(np.float32)  # noqa: E731
    return SparseFrame(radiance=np.where(mask[..., None], rand(3), 0).astype(np.float32), mask=mask,
                       variance=np.where(mask, rand() * 0.01, 0).astype(np.float32), albedo=rand(3),
                       normal=rand(3) * 2 - 1, depth=rand(), visibility=rand(), spp=16)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--rate", type=float, default=0.2)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--weights", default=None, help="shipped name or .pt path (default: gan-cpu)")
    args = parser.parse_args()

    from gmcpt.completion.learned import gan_precompletion
    from gmcpt.image.domain import WorkingDomain
    from gmcpt.gan.weights import load_generator

    start = time.perf_counter()
    generator, meta = load_generator(args.weights)
    load_s = time.perf_counter() - start
    frame, domain = synthetic_frame(args.res, args.rate), WorkingDomain()
    results = {"resolution": args.res, "rate": args.rate, "parameters": sum(p.numel() for p in generator.parameters()),
               "weights": meta.get("name", args.weights), "load_weights_s": round(load_s, 4),
               "cpu_count": os.cpu_count(), "load_average": os.getloadavg()[0], "per_threads": {}}
    for threads in args.threads:
        os.environ["GMCPT_TORCH_THREADS"] = str(threads)  # read by gan_precompletion on each call
        gan_precompletion(frame, domain, args.weights)  # warm-up
        times = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            working, factor, _ = gan_precompletion(frame, domain, args.weights)
            domain.inverse(working, factor)
            times.append(time.perf_counter() - start)
        results["per_threads"][threads] = {"median_s": round(statistics.median(times), 4),
                                           "min_s": round(min(times), 4), "max_s": round(max(times), 4)}
        print(f"{args.res}x{args.res} at rate {args.rate}, {threads} thread(s): median {statistics.median(times):.3f} s "
              f"(min {min(times):.3f}, max {max(times):.3f}) over {args.repeats} calls; target <= 0.5 s",
              file=sys.stderr)
    print(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
