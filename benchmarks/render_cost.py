#!/usr/bin/env python3
"""Cost of the masked render against Mitsuba's stock ``path`` at the same spp.

For each scene and spp, the stock full-frame render and the masked render
(feature pass + compacted path tracing, no completion) at each rate run
interleaved, ``--repeats`` rounds after one warm-up round (kernel
compilation); the table shows medians and the ratio masked / full beside the
target ``rate + 0.05``, both in wall-clock time and in CPU time of this
process (all its threads). CPU time is the cost measure that other programs
on a shared machine disturb least; the verdict uses it.

    python benchmarks/render_cost.py [--res 256] [--spp 16 64] [--repeats 3]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED_BREAKFAST = ROOT.parent / "shared" / "scenes" / "breakfast-room" / "scene.xml"
BUNDLED = ROOT / "scenes" / "still-life" / "scene.xml"
RATES = (0.2, 0.3, 0.5, 1.0)


def timed(function) -> tuple[float, float]:
    """(wall seconds, CPU seconds of this process) spent in ``function``."""
    wall, cpu = time.perf_counter(), time.process_time()
    function()
    return time.perf_counter() - wall, time.process_time() - cpu


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--res", type=int, default=256)
    parser.add_argument("--spp", type=int, nargs="+", default=[16, 64])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenes", nargs="+", default=[str(BUNDLED), str(SHARED_BREAKFAST)])
    args = parser.parse_args()

    import drjit as dr
    import gmcpt  # noqa: F401
    import mitsuba as mi
    from gmcpt.render import RenderSettings, render_sparse_frame
    from gmcpt.scene import load_scene

    mi.set_log_level(mi.LogLevel.Error)
    rows = []
    for scene_path in map(Path, args.scenes):
        if not scene_path.is_file():
            print(f"skipping {scene_path}: not found (the shared scenes are absent)", flush=True)
            continue
        scene = load_scene(scene_path, resolution=(args.res, args.res))
        masked = scene.integrator()
        nested = masked.integrator if hasattr(masked, "integrator") else masked
        for spp in args.spp:
            def full():
                image = mi.render(scene, integrator=nested, spp=spp, seed=1)
                dr.eval(image)
                dr.sync_thread()

            def sparse(rate):
                return lambda: render_sparse_frame(scene, nested, settings=RenderSettings(rate=rate, spp=spp, seed=1))

            jobs = [("full", full)] + [(rate, sparse(rate)) for rate in RATES]
            for _, job in jobs:  # warm-up: kernel compilation
                job()
            samples = {name: [] for name, _ in jobs}
            for round_index in range(args.repeats):
                for name, job in jobs:
                    samples[name].append(timed(job))
                print(f"  {scene_path.parent.name} spp={spp}: round {round_index + 1}/{args.repeats} done", flush=True)
            def median(name, which):
                return statistics.median(sample[which] for sample in samples[name])
            for rate in RATES:
                rows.append((scene_path.parent.name, spp, rate, median("full", 0), median(rate, 0),
                             median(rate, 0) / median("full", 0), median(rate, 1) / median("full", 1), rate + 0.05))

    print(f"\nmasked render (features + traced pixels) vs stock path, {args.res}x{args.res}, "
          f"median of {args.repeats}")
    header = (f"{'scene':<16}{'spp':>5}{'rate':>6}{'full s':>9}{'masked s':>10}{'wall ratio':>12}"
              f"{'CPU ratio':>11}{'target':>8}  ok")
    print(header)
    print("-" * len(header))
    for scene_name, spp, rate, full_s, masked_s, wall_ratio, cpu_ratio, target in rows:
        print(f"{scene_name:<16}{spp:>5}{rate:>6.2f}{full_s:>9.3f}{masked_s:>10.3f}{wall_ratio:>12.3f}"
              f"{cpu_ratio:>11.3f}{target:>8.2f}  {'yes' if cpu_ratio <= target else 'NO'}")
    return 0 if all(row[6] <= row[7] for row in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
