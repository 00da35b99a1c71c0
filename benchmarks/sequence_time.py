"""How near a timed sequence's frames come to their time: ``gmcpt batch SCENE --frames 0:N --time S`` at a few S.

    python benchmarks/sequence_time.py [--scene scenes/cornell-box/scene.xml] [--res 128] [--frames 16]
        [--seconds 0.25 0.5 1]

A frame's seconds are the batch summary's: from loading the frame's scene to its files written. The first
``--warm`` frames (compiling kernels, the pace not yet read) are left out. Prints, for each S, the warm frames'
seconds over S (mean, least, most) and how many lie within 10% of it; then the same for a sequence that spends the
timed frames' median budget on every frame, over its own mean: the spread of the machine itself, which no pacing
can undercut.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def frame_seconds(scene: str, res: int, frames: int, spend: list[str]) -> tuple[list[float], list[float]]:
    """Each frame's seconds and budget in a sequence of ``frames`` frames of ``scene`` at ``res`` x ``res`` that
    spends ``spend`` (``["--time", S]`` or ``["--budget", B]``)."""
    from gmcpt.cli.batch import main as batch

    with tempfile.TemporaryDirectory() as out, contextlib.redirect_stdout(io.StringIO()):
        status = batch([scene, "--frames", f"0:{frames}", *spend, "--res", str(res), str(res), "--out", out, "-q"])
        if status:
            raise SystemExit(status)
        summary = json.loads((Path(out) / "batch-summary.json").read_text())
        budgets = [json.loads(Path(item["output"]).with_suffix(".json").read_text())["budget"]
                   for item in summary["items"]]
    return [item["seconds"] for item in summary["items"]], budgets


def spread(ratios: np.ndarray) -> str:
    within = int((np.abs(ratios - 1) <= 0.1).sum())
    return (f" mean {ratios.mean():.3f}, least {ratios.min():.3f}, most {ratios.max():.3f}, {within} of {ratios.size} "
            f"within 10%")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-box" / "scene.xml"))
    parser.add_argument("--res", type=int, default=128)
    parser.add_argument("--frames", type=int, default=16)
    parser.add_argument("--warm", type=int, default=2)
    parser.add_argument("--seconds", type=float, nargs="+", default=[0.25, 0.5, 1.0])
    args = parser.parse_args()
    print(f"{Path(args.scene).parent.name}, {args.res}x{args.res}, frames {args.warm}..{args.frames - 1}: "
          f"a frame's seconds / --time")
    for seconds in args.seconds:
        spent, budgets = frame_seconds(args.scene, args.res, args.frames, ["--time", str(seconds)])
        print(f"  --time {seconds:g}:" + spread(np.array(spent[args.warm:]) / seconds))
        # the machine's own spread: the same work every frame, at the budget the timed frames settled on
        budget = float(np.median(budgets[args.warm:]))
        fixed, _ = frame_seconds(args.scene, args.res, args.frames, ["--budget", f"{budget:.3f}"])
        fixed = np.array(fixed[args.warm:])
        print(f"    --budget {budget:.2f} (its median):" + spread(fixed / fixed.mean()) + " (over its own mean)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
