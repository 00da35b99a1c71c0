#!/usr/bin/env python3
"""A sequence on Ray in chunks (:mod:`gmcpt.cli.sequence_ray`) against the same sequence in one process: the PSNR
gap, and the flicker at chunk borders against inside chunks. Each seed runs ``gmcpt batch --history H`` once in
one process and once with ``--ray local --chunk C``, then reads the frames back.

Flicker is :func:`gmcpt.evaluation.stability.surface_flicker` of one frame change at a time (two independent
references a frame, so their noise is no floor), pooled as an RMS over the changes: the changes into a chunk's
first frame (borders), the changes across the frames cross-faded into the next chunk and into its first frame
(blends), and the others after the first ``H`` frames (inside), for both runs. A step would show as the chunked
run's borders or blends above its inside and above the one-process run's same changes.

    python benchmarks/sequence_chunks.py [--scene scenes/cornell-box/scene.xml] [--res 64] [--frames 24]
        [--chunk 8] [--history 8] [--budget 2] [--seeds 0 1 2] [--reference-spp 1024]
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def batch(args, seed: int, out: Path, ray: bool) -> None:
    """``gmcpt batch`` of the sequence into ``out``, in one process or on a local Ray cluster in chunks."""
    command = [sys.executable, "-m", "gmcpt", "batch", args.scene, "--frames", f"0:{args.frames}", "--res",
               str(args.res), str(args.res), "--budget", str(args.budget), "--history", str(args.history),
               "--seed", str(seed), "--out", str(out), "-q"]
    command += ["--ray", "local", "--chunk", str(args.chunk)] if ray else []
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    if result.returncode:
        raise SystemExit(result.stderr)


def frames(out: Path) -> list[np.ndarray]:
    """The RGB images of a batch's frames, in order."""
    from gmcpt.io.exr import read_exr

    items = json.loads((out / "batch-summary.json").read_text())["items"]
    return [np.stack([layers[c] for c in "RGB"], axis=-1) for layers in
            (read_exr(Path(item["output"])) for item in items)]


def truth(args) -> tuple[list, list, list]:
    """Two independent references of every frame and its geometry (:class:`FrameGeometry`)."""
    from gmcpt.evaluation.stability import FrameGeometry
    from gmcpt.render.kernels import render_native
    from gmcpt.render.scene import load_scene, path_integrator
    from gmcpt.seeds import SEQUENCE_REFERENCE_SEEDS
    from gmcpt.temporal.survey import geometry

    firsts, seconds, geometries = [], [], []
    for frame in range(args.frames):
        scene = load_scene(args.scene, (args.res, args.res), {"frame": str(frame)})
        sensor, integrator = scene.sensors()[0], path_integrator(scene)
        for seed, into in zip(SEQUENCE_REFERENCE_SEEDS, (firsts, seconds)):
            into.append(render_native(scene, sensor, integrator, args.reference_spp, seed + frame,
                                      any_size=True).reshape(args.res, args.res, 3))
        geometries.append(FrameGeometry(*geometry(scene, sensor)))
    return firsts, seconds, geometries


def changes(images, firsts, seconds, geometries) -> dict[int, float]:
    """Frame change t (t-1 -> t) -> its surface flicker."""
    from gmcpt.evaluation.stability import surface_flicker

    return {t: surface_flicker(images[t - 1:t + 1], firsts[t - 1:t + 1], geometries[t - 1:t + 1],
                               seconds[t - 1:t + 1]) for t in range(1, len(images))}


def pooled(figures: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(figures))))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-box" / "scene.xml"))
    parser.add_argument("--res", type=int, default=64)
    parser.add_argument("--frames", type=int, default=24)
    parser.add_argument("--chunk", type=int, default=8)
    parser.add_argument("--history", type=int, default=8)
    parser.add_argument("--budget", type=float, default=2.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--reference-spp", type=int, default=1024)
    args = parser.parse_args()

    import gmcpt  # noqa: F401  (variant)
    from gmcpt.image.metrics import psnr
    from gmcpt.cli.sequence_ray import blend_frames

    firsts, seconds, geometries = truth(args)
    references = [(a + b) / 2 for a, b in zip(firsts, seconds)]
    blend = min(blend_frames(args.history), args.chunk, args.history)
    borders = list(range(args.chunk, args.frames, args.chunk))
    places = {"borders": borders, "blends": [t for b in borders for t in range(b - blend, b + 1)]}
    places["inside"] = [t for t in range(args.history + 1, args.frames) if t not in places["blends"]]
    blended = {t for b in borders for t in range(b - blend, b)}
    gaps, figures = {"blended": [], "others": []}, {(run, where): [] for run in ("one", "chunks") for where in places}
    with tempfile.TemporaryDirectory() as folder:
        for seed in args.seeds:
            runs = {}
            for run, ray in (("one", False), ("chunks", True)):
                batch(args, seed, Path(folder) / f"{run}-{seed}", ray)
                runs[run] = frames(Path(folder) / f"{run}-{seed}")
            psnrs = {run: [psnr(image, reference) for image, reference in zip(images, references)]
                     for run, images in runs.items()}
            gap = [c - o for c, o in zip(psnrs["chunks"], psnrs["one"])]
            for t in range(args.chunk, args.frames):
                gaps["blended" if t in blended else "others"].append(gap[t])
            for run, images in runs.items():
                figure = changes(images, firsts, seconds, geometries)
                for where, changed in places.items():
                    figures[run, where] += [figure[t] for t in changed]
            print(f"seed {seed}: PSNR one process {np.mean(psnrs['one']):.2f} dB, chunks {np.mean(psnrs['chunks']):.2f}"
                  f" dB; chunked frames' gap {np.mean(gap[args.chunk:]):+.3f} dB (worst {min(gap):+.3f})", flush=True)
    for kind, gap in gaps.items():
        print(f"PSNR gap, chunks - one process, frames after the first chunk, {kind}: mean {np.mean(gap):+.3f} dB "
              f"over {len(gap)} frames, range {min(gap):+.3f} .. {max(gap):+.3f}")
    for run in ("one", "chunks"):
        print(f"flicker {run:6s}: " + ", ".join(f"{where} {pooled(figures[run, where]):.3f} "
                                                f"({len(figures[run, where])} changes)" for where in places))
    return 0


if __name__ == "__main__":
    sys.exit(main())
