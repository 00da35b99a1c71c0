"""``gmcpt reference``: a converged reference EXR of a scene, for ``gmcpt render --reference``.

    gmcpt reference SCENE.xml --spp 4096 --out REF.exr [--res W H] [-D NAME=VALUE]

The scene's own integrator (the nested one, for a scene that names
``masked_path``) renders every pixel in passes of ``--pass-spp`` samples with
seeds ``--seed``, ``--seed`` + 1, ... averaged, as the evaluation's cached
references are (:func:`gmcpt.evaluation.reference.render_full`): at the same
size, spp, seed and ``--pass-spp 256`` the pixels are the same. Progress is a bar (a line per pass
off a terminal) with the time left; the file is written under a temporary name
and renamed when complete.
"""
from __future__ import annotations

import argparse
import sys
from typing import Callable

from ..errors import GmcptError
from ..runtime import interrupts
from ..seeds import REFERENCE_FIRST_SEED as DEFAULT_SEED
from .command import Parser, mitsuba_command, stamped_say



def build_parser() -> argparse.ArgumentParser:
    parser = Parser("reference", "Render a converged reference EXR of a scene (every pixel, many samples).")
    parser.add_argument("scene", help="Mitsuba 3 scene XML")
    parser.add_argument("--out", required=True, help="output EXR (required); its folder is created if its parent exists")
    parser.add_argument("--spp", type=int, default=4096, help="samples per pixel")
    parser.add_argument("--pass-spp", type=int, default=64,
                        help="samples per pass, one step of the progress (256: the evaluation's references)")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help="seed of the first pass")
    parser.add_argument("--res", type=int, nargs=2, metavar=("W", "H"), help="film resolution (default: the scene's)")
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                        help="set a scene parameter ($NAME in the XML); repeatable (default: none)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def _validate(args) -> dict:
    """The scene parameters; every check on the command line before any work."""
    from ..io.files import check_not_inputs, check_output
    from ..limits import check_resolution, check_seed, check_spp
    from ..render.scene import scene_inputs

    if not args.out.lower().endswith(".exr"):
        raise GmcptError(f"--out must name an .exr file, got {args.out}")
    check_output(args.out)
    check_spp(args.spp, "--spp")
    check_spp(args.pass_spp, "--pass-spp")
    check_seed(args.seed, "--seed")
    if args.res is not None:
        check_resolution(*args.res, 1, "--res")
    if any("=" not in define for define in args.defines):
        raise GmcptError(f"-D expects NAME=VALUE, got {next(d for d in args.defines if '=' not in d)!r}")
    check_not_inputs([args.out], {"scene file": scene_inputs(args.scene)})
    return dict(define.split("=", 1) for define in args.defines)


def render(args, say=lambda message: None, committed: Callable[[], None] | None = None) -> None:
    """Render the reference ``args`` describe and write it to ``args.out``; ``committed`` runs once it is there."""
    from pathlib import Path

    from ..evaluation.reference import render_full
    from ..io.exr import atomic_output, write_exr
    from ..io.files import make_folder
    from ..limits import check_resolution
    from ..runtime.progress import Progress
    from ..render.scene import load_scene, scene_sensor

    parameters = _validate(args)
    scene = load_scene(args.scene, tuple(args.res) if args.res else None, parameters)
    width, height = (int(side) for side in scene_sensor(scene, path=args.scene).film().crop_size())
    check_resolution(width, height, 1)
    passes = max(1, args.spp // args.pass_spp)
    spp = passes * min(args.pass_spp, args.spp)
    say(f"{args.scene}: {width}x{height} px, {spp} spp in {passes} passes")
    with Progress(passes, "reference", unit="pass", say=say, quiet=args.quiet) as bar:
        started = []

        def on_pass(message: str) -> None:  # render_full announces each pass: the one before it is done
            if started:
                bar.update()
            started.append(message)
        image = render_full(scene, args.spp, args.seed, args.pass_spp, on_pass, Path(args.scene).parent.name)
        bar.update()
    make_folder(args.out)
    with atomic_output(args.out, committed) as temporary:
        write_exr(temporary, {c: image[..., i] for i, c in enumerate("RGB")},
                  {"spp": spp, "seed": args.seed, "scene": str(Path(args.scene).resolve()), "parameters": parameters})
    say(f"wrote {args.out}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt reference``; returns the exit status."""
    def work(args) -> int:
        render(args, stamped_say("reference", args.quiet), committed=interrupts.settle)
        return 0
    return mitsuba_command(sys.argv[1:] if argv is None else list(argv), build_parser, work)


if __name__ == "__main__":
    sys.exit(main())
