"""How near a timed sequence's frames come to their time: ``gmcpt batch SCENE --frames 0:N --time S`` at a few S.

    python benchmarks/sequence_time.py [--scene scenes/cornell-box/scene.xml] [--res 128] [--frames 16]
        [--seconds 0.25 0.5 1]

A frame's seconds are the batch summary's: from loading the frame's scene to its files written. The first
``--warm`` frames (compiling kernels, the pace not yet read) are left out. Prints, for each S, the warm frames'
seconds over S (mean, least, most) and how many lie within 10% of it.
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


def frame_seconds(scene: str, res: int, frames: int, seconds: float) -> list[float]:
    """Each frame's seconds in a timed sequence of ``frames`` frames of ``scene`` at ``res`` x ``res``."""
    from gmcpt.batch import main as batch

    with tempfile.TemporaryDirectory() as out, contextlib.redirect_stdout(io.StringIO()):
        status = batch([scene, "--frames", f"0:{frames}", "--time", str(seconds), "--res", str(res), str(res),
                        "--out", out, "-q"])
        if status:
            raise SystemExit(status)
        summary = json.loads((Path(out) / "batch-summary.json").read_text())
    return [item["seconds"] for item in summary["items"]]


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
        ratios = np.array(frame_seconds(args.scene, args.res, args.frames, seconds)[args.warm:]) / seconds
        within = int((np.abs(ratios - 1) <= 0.1).sum())
        print(f"  --time {seconds:g}: mean {ratios.mean():.3f}, least {ratios.min():.3f}, most {ratios.max():.3f}, "
              f"{within} of {ratios.size} within 10%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
