#!/usr/bin/env python3
"""A one-shot process's first completion against a cold OIDN, each in a fresh process, with the generator's
cache empty, holding the converted network only, and warm.

Renders the still life once at ``--size`` (``--rate`` x ``--spp``, and the full frame at the same samples, OIDN's
input: :func:`completion_vs_oidn.render_inputs`). Then, ``--repeats`` rounds, each running in turn, in a fresh
process that reads the frame from disk and times one call:

- ``empty``: the completion (``--method``) with an empty ``$GMCPT_CACHE`` (a new machine's: the generator is
  converted in PyTorch, then compiled); in the first ``--empty-repeats`` rounds only, it costs seconds;
- ``converted``: the completion with the converted network cached but not the compiled one (what a process
  found before the compiled network was cached);
- ``warm``: the completion with both cached (every later one-shot process);
- ``oidn``: Intel OIDN on the full frame (its first call in the process: the library's import and set-up).

Prints the medians, the stages of the completion, the whole child process's wall time, and each completion's
ratio to OIDN's median (the figure the issue's "at most 3x" reads).

    python benchmarks/cold_start.py [--size 256x256] [--repeats 7] [--empty-repeats 3] [--method gan_oidn]
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

KINDS = ("empty", "converted", "warm", "oidn")


def measure(frame_path: str, kind: str, method: str) -> dict:
    """In this (fresh) process: the seconds of one call of ``kind`` and the completion's stages."""
    import numpy as np

    from gmcpt.frame import PIXEL_BUFFERS, SparseFrame

    data = np.load(frame_path)
    frame = SparseFrame(spp=int(data["spp"]), **{name: data[name] for name in PIXEL_BUFFERS})
    if kind == "oidn":
        from gmcpt.image.denoise import denoise_oidn

        start = time.perf_counter()
        denoise_oidn(data["full"], frame.albedo, frame.normal)
        return {"seconds": time.perf_counter() - start, "stages": {}}
    from gmcpt.completion import complete

    start = time.perf_counter()
    result = complete(frame, method)
    return {"seconds": time.perf_counter() - start, "stages": result.timings}


def child(frame_path: Path, kind: str, method: str, cache: Path) -> dict:
    """One fresh process's measurement, with ``cache`` as its ``$GMCPT_CACHE``, and its whole wall time."""
    command = [sys.executable, __file__, "--child", str(frame_path), kind, "--method", method]
    env = {**os.environ, "GMCPT_CACHE": str(cache)}
    start = time.perf_counter()
    output = subprocess.run(command, check=True, capture_output=True, text=True, env=env).stdout
    return {**json.loads(output.strip().splitlines()[-1]), "process_s": time.perf_counter() - start}


def cache_for(kind: str, folder: Path, warm: Path) -> Path:
    """The ``$GMCPT_CACHE`` a run of ``kind`` starts with: a new empty one, or a copy of ``warm`` (less its
    compiled networks for ``converted``)."""
    cache = Path(tempfile.mkdtemp(dir=folder, prefix=f"{kind}-"))
    if kind in ("converted", "warm"):
        shutil.copytree(warm, cache, dirs_exist_ok=True)
    if kind == "converted":
        shutil.rmtree(cache / "generators" / "compiled", ignore_errors=True)
    return cache


def run_rounds(frame_path: Path, args, folder: Path) -> dict[str, list[dict]]:
    """Every kind in turn, ``args.repeats`` rounds (``empty`` in the first ``args.empty_repeats``)."""
    warm = folder / "warm-cache"
    child(frame_path, "warm", args.method, warm)  # converts and compiles once, untimed
    runs = {kind: [] for kind in KINDS}
    for round_index in range(args.repeats):
        for kind in KINDS:
            if kind == "empty" and round_index >= args.empty_repeats:
                continue
            cache = cache_for(kind, folder, warm)
            runs[kind].append(child(frame_path, kind, args.method, cache))
            shutil.rmtree(cache, ignore_errors=True)
            print(f"round {round_index + 1}: {kind} {runs[kind][-1]['seconds']:.3f} s", flush=True)
    return runs


def median(runs: list[dict], key: str, stage: bool = False) -> float:
    return statistics.median(run["stages"].get(key, 0.0) if stage else run[key] for run in runs)


def report(runs: dict[str, list[dict]], args, load: tuple[float, float]) -> None:
    oidn = median(runs["oidn"], "seconds")
    print(f"\n{args.method} at {args.size}, {args.rate} x {args.spp} spp; medians, seconds; "
          f"load average {load[0]:.2f} before, {load[1]:.2f} after")
    header = (f"{'cache':>10}{'runs':>5}{'call':>8}{'/ OIDN':>8}{'process':>9}"
              f"{'load_weights':>13}{'pre_completion':>15}{'denoise':>8}")
    print(header, "-" * len(header), sep="\n")
    for kind, kind_runs in runs.items():
        seconds = median(kind_runs, "seconds")
        stages = "".join(f"{median(kind_runs, name, stage=True):>{width}.3f}" for name, width in
                         (("load_weights_s", 13), ("pre_completion_s", 15), ("denoise_s", 8)))
        print(f"{kind:>10}{len(kind_runs):>5}{seconds:>8.3f}{seconds / oidn:>7.1f}x"
              f"{median(kind_runs, 'process_s'):>9.2f}{stages if kind != 'oidn' else ''}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", default="256x256", help="WIDTHxHEIGHT")
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "still-life" / "scene.xml"))
    parser.add_argument("--rate", type=float, default=0.3)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--method", default="gan_oidn")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--empty-repeats", type=int, default=3)
    parser.add_argument("--child", nargs=2, metavar=("FRAME", "KIND"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(measure(args.child[0], args.child[1], args.method)))
        return 0

    from completion_vs_oidn import render_inputs

    width, height = map(int, args.size.lower().split("x"))
    with tempfile.TemporaryDirectory() as folder:
        frame_path = render_inputs(Path(args.scene), width, height, args.rate, args.spp, Path(folder))
        before = os.getloadavg()[0]
        runs = run_rounds(frame_path, args, Path(folder))
        report(runs, args, (before, os.getloadavg()[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
