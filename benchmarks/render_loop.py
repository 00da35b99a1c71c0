"""Seconds a frame of an animation rendered from Python, the way a Mitsuba user writes it: the scene loaded once, the
camera and a shape moved through ``mi.traverse`` before each ``mi.render``.

    python benchmarks/render_loop.py [--scene scenes/cornell-box/scene.xml] [--res 128] [--frames 10] [--spp 2]

Contenders, each over the same frames (the camera and the Cornell box's blue sphere turned a degree a frame about
the vertical), at ``--spp`` samples a pixel a frame:

- ``mi.render + OIDN, literal``: the new transforms set as they are; Dr.Jit bakes them into the kernels as
  literals, so every frame compiles its kernels again;
- ``mi.render + OIDN, opaque``: the same values made opaque (``dr.make_opaque``): the kernels compile once;
- ``mi.render + OIDN, file a frame``: the scene file loaded again for each frame (its ``$frame``), as a renderer
  that writes one scene file a frame does;
- ``masked_path history=8``: the project's integrator in a sequence (its samples reused over 8 frames), opaque.

The two ``mi.render`` contenders each render the frame, one pass of Mitsuba's ``aov`` integrator for the guides, then
OIDN (:func:`gmcpt.evaluation.sequences.denoised_with_aov_guides`). The first ``--warm`` frames are left out of the
means (the first compile of every contender). Prints one line a contender, side by side.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def turner(mi, params, key: str):
    """A function of a frame that sets ``params[key]`` (a ``to_world``) to its frame-0 value turned that many degrees
    about the vertical through the origin."""
    base = mi.ScalarTransform4f(np.array(params[key].matrix, dtype=np.float32).reshape(4, 4))

    def at(frame: int):
        return mi.ScalarTransform4f().rotate([0, 1, 0], float(frame)) @ base
    return at


def frames_seconds(mi, dr, scene, params, movers: dict, frames: int, opaque: bool, render) -> list[float]:
    """Seconds of each frame: the parameters moved (made opaque or not), then ``render()``, all charged."""
    seconds = []
    for frame in range(frames):
        start = time.perf_counter()
        for key, at in movers.items():
            params[key] = at(frame)
            if opaque:
                dr.make_opaque(params[key])
        params.update()
        render(frame)
        seconds.append(time.perf_counter() - start)
    return seconds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", default=str(ROOT / "scenes" / "cornell-box" / "scene.xml"))
    parser.add_argument("--res", type=int, default=128)
    parser.add_argument("--frames", type=int, default=10)
    parser.add_argument("--warm", type=int, default=2, help="first frames left out of the means")
    parser.add_argument("--spp", type=int, default=2)
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()

    import drjit as dr
    import mitsuba as mi

    import gmcpt  # noqa: F401  (variant, plugins)
    from gmcpt.evaluation.sequences import AOV_GUIDES, denoised_with_aov_guides
    from gmcpt.render.scene import path_integrator

    rows = {}
    for name, opaque in (("mi.render + OIDN, literal", False), ("mi.render + OIDN, opaque", True),
                         ("mi.render + OIDN, file a frame", False), ("masked_path history=8", True)):
        scene = mi.load_file(args.scene, res=args.res)  # a scene of its own: no contender inherits another's kernels
        params = mi.traverse(scene)
        movers = {key: turner(mi, params, key) for key in params.keys()
                  if key.endswith("to_world") and ("camera" in key or "plastic_sphere" in key)}
        if name.endswith("file a frame"):
            movers, aov = {}, mi.load_dict(AOV_GUIDES)

            def render(frame):
                loaded = mi.load_file(args.scene, res=args.res, frame=frame)
                noisy = np.asarray(mi.render(loaded, integrator=path_integrator(loaded), spp=args.spp, seed=frame))
                denoised_with_aov_guides(loaded, aov, noisy.reshape(-1, 3), args.spp, frame)
        elif name.startswith("masked_path"):
            integrator = mi.load_dict({"type": "masked_path", "history": 8, "budget": args.spp})

            def render(frame):
                mi.render(scene, integrator=integrator)
        else:
            integrator, aov = path_integrator(scene), mi.load_dict(AOV_GUIDES)

            def render(frame):
                noisy = np.asarray(mi.render(scene, integrator=integrator, spp=args.spp, seed=frame))
                denoised_with_aov_guides(scene, aov, noisy.reshape(-1, 3), args.spp, frame)
        seconds = frames_seconds(mi, dr, scene, params, movers, args.frames, opaque, render)
        rows[name] = {"mean_s": float(np.mean(seconds[args.warm:])), "first_s": seconds[0], "seconds": seconds}
    print(f"{args.res}x{args.res}, {args.spp} samples a pixel a frame, frames {args.warm}..{args.frames - 1} "
          f"(after {args.warm} warm-up):")
    for name, row in rows.items():
        print(f"  {name:31s} {row['mean_s']:.3f} s a frame (first frame {row['first_s']:.2f} s)")
    if args.json:
        Path(args.json).write_text(json.dumps({"settings": vars(args), "rows": rows}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
