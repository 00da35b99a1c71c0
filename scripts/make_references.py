#!/usr/bin/env python3
"""Render (or find cached) the high-spp references the evaluations compare against.

    python scripts/make_references.py [--res 256] [--spp 4096] [--scenes ...]

Cached under $GMCPT_CACHE (default ~/.cache/gmcpt/references); rerunning is free.
"""
import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENES = [ROOT / "scenes" / "cornell-box" / "scene.xml", ROOT / "scenes" / "still-life" / "scene.xml",
                  ROOT.parent / "shared" / "scenes" / "breakfast-room" / "scene.xml"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, default=4096)
    parser.add_argument("--scenes", nargs="+", default=[str(p) for p in DEFAULT_SCENES])
    args = parser.parse_args()

    import gmcpt  # noqa: F401
    from gmcpt.reference import render_reference

    start = time.perf_counter()
    for scene in map(Path, args.scenes):
        if not scene.is_file():
            print(f"skipping {scene}: not found", flush=True)
            continue
        render_reference(scene, args.res, args.spp,
                         progress=lambda m: print(f"[{time.perf_counter() - start:7.1f}s] {m}", flush=True))
        print(f"{scene.parent.name}: reference ready", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
