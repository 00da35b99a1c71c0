#!/usr/bin/env python3
"""What a batch sequence's frame costs before it renders: its scene set on one held scene, or loaded whole.

    python benchmarks/frame_scene.py SCENE.xml [--frames 0:10] [--res 256 256] [--rounds 3]

``SCENE.xml`` reads ``$frame`` (an animation ``gmcpt batch --frames`` renders). For each round, the frames in order
through :class:`gmcpt.render.frames.SceneFrames` (the first loads, the others set what their ``$frame`` changes),
then each frame loaded whole (``load_scene``, as ``gmcpt batch`` did before), in turn. Prints each way's median
seconds a frame over the frames after the first (the fastest round's), their ratio, and how many frames the held
scene loaded whole. Only the scene is timed, not its render: ``gmcpt batch``'s records give a frame's stages
(``scene_s`` first).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def frame_range(text: str) -> range:
    start, stop = (int(part) for part in text.split(":"))
    return range(start, stop)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("--frames", type=frame_range, default=range(0, 10))
    parser.add_argument("--res", type=int, nargs=2, default=(256, 256), metavar=("WIDTH", "HEIGHT"))
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import gmcpt  # noqa: F401 (picks the variant)
    from gmcpt.render.frames import SceneFrames
    from gmcpt.render.scene import load_scene

    held, whole, loads = [], [], 0
    for _ in range(args.rounds):
        frames, seconds = SceneFrames(args.scene, tuple(args.res)), []
        for frame in args.frames:
            start = time.perf_counter()
            frames.at({"frame": str(frame)})
            seconds.append(time.perf_counter() - start)
        held.append(statistics.median(seconds[1:]))
        loads = frames.loads
        seconds = []
        for frame in args.frames:
            start = time.perf_counter()
            load_scene(args.scene, tuple(args.res), {"frame": str(frame)})
            seconds.append(time.perf_counter() - start)
        whole.append(statistics.median(seconds[1:]))
    print(f"{args.scene}, frames {args.frames.start}-{args.frames.stop - 1}, {args.res[0]}x{args.res[1]}, "
          f"{args.rounds} rounds (the fastest round's median a frame after the first):")
    print(f"  set on one held scene  {min(held):.4f} s   ({loads} of {len(args.frames)} frames loaded whole)")
    print(f"  loaded whole           {min(whole):.4f} s")
    print(f"  held / whole           {min(held) / min(whole):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
