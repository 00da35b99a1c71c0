#!/usr/bin/env python3
"""Render (or find cached) the high-spp references the evaluations compare against.

    python scripts/make_references.py [--res 256] [--spp 4096] [--scenes cornell-box still-life ...] [--seed N]

A second reference with another ``--seed`` (for example 2000003) is independent
of the first; the PSNR between the two tells how noisy the references are.

Scenes are those of :mod:`gmcpt.evaluation.scenes` (default: the quality scenes).
Cached under $GMCPT_CACHE (default ~/.cache/gmcpt/references); rerunning is free.
"""
import argparse
import sys
import time


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, default=4096)
    parser.add_argument("--scenes", nargs="+", help="names from gmcpt.evaluation.scenes")
    parser.add_argument("--seed", type=int, default=1_000_003, help="first sampler seed (default: the evaluations')")
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    from gmcpt.evaluation.scenes import by_name

    try:
        scenes = by_name(args.scenes)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    start = time.perf_counter()
    for scene in scenes:
        if not scene.available():
            print(f"skipping {scene.name}: {scene.path} not found", flush=True)
            continue
        scene.reference(args.res, args.spp, seed=args.seed,
                        progress=lambda m: print(f"[{time.perf_counter() - start:7.1f}s] {m}", flush=True))
        print(f"{scene.name}: reference ready", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
