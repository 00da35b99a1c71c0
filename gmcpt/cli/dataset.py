"""``gmcpt dataset``: render (or resume) the procedural dataset, or one of views of real scene files.

    gmcpt dataset --out data/procedural --train 300 --val 10 --test 6
    gmcpt dataset --real data/train-scenes --out data/real-train --train 40 --val 4

Each split's scenes come from its own seed range; an interrupted build resumes.
"""
from __future__ import annotations

import argparse
import json
import sys

from ..errors import GmcptError
from ..runtime import interrupts
from .command import Parser


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("dataset", "Render (or resume) the procedural training data of the GAN.\n"
                    "Each split's scenes come from its own seed range; an interrupted build resumes.")
    parser.add_argument("--out", required=True, help="dataset folder (required; created, resumed if it exists)")
    parser.add_argument("--train", type=int, default=200, help="training scenes (seeds 0..)")
    parser.add_argument("--val", type=int, default=10, help="validation scenes (seeds 1000000..)")
    parser.add_argument("--test", type=int, default=0, help="held-out evaluation scenes (seeds 2000000..)")
    parser.add_argument("--res", type=int, nargs="+", default=[128], metavar="N",
                        help="train/val resolution: N, or W H as elsewhere (the scenes are square: W = H)")
    parser.add_argument("--ref-spp", type=int, default=512, help="train/val reference spp")
    parser.add_argument("--test-res", type=int, default=256, help="test resolution")
    parser.add_argument("--test-ref-spp", type=int, default=4096, help="test reference spp")
    parser.add_argument("--spp", type=int, default=16, help="spp of the sparse inputs")
    parser.add_argument("--rate", type=float, nargs=2, default=(0.15, 0.5), metavar=("LOW", "HIGH"),
                        help="range of the per-scene sampling rate")
    parser.add_argument("--real", metavar="DIR",
                        help="render random views of the scene files under DIR (FOLDER/scene.xml, "
                        "FOLDER/rand_sceneN.xml, as scripts/import_scenes.py writes) instead of procedural "
                        "scenes; train and val only (default: procedural)")
    parser.add_argument("--workers", type=int, default=1, help="render processes (0: in this process)")
    parser.add_argument("--threads", type=int, default=0,
                        help="Dr.Jit threads per worker (0: all cores; with --ray: CPUs per task, default 1)")
    parser.add_argument("--ray", metavar="ADDRESS",
                        help="render each scene as a Ray task: local (start a cluster here), auto, HOST:PORT "
                        "(default: --workers processes here)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def _square_side(res: list[int]) -> int:
    """The side ``--res N`` or ``--res W H`` gives: every other --res takes W H, the dataset's images are square."""
    if len(res) > 2 or len(set(res)) != 1:
        given = " ".join(map(str, res))
        raise GmcptError(f"--res takes N, or W H with W = H (the dataset's scenes are square), got {given}")
    return res[0]


def spec_from_args(args) -> "DatasetSpec":  # noqa: F821
    from ..dataset.build import DatasetSpec, SplitSpec

    side = _square_side(args.res)
    splits = [SplitSpec("val", args.val, side, args.ref_spp), SplitSpec("train", args.train, side, args.ref_spp),
              SplitSpec("test", args.test, args.test_res, args.test_ref_spp)]
    if not 0 < args.rate[0] <= args.rate[1] <= 1:
        raise GmcptError(f"--rate must satisfy 0 < LOW <= HIGH <= 1, got {args.rate}")
    if args.spp < 1 or args.ref_spp < 1 or args.test_ref_spp < 1:
        raise GmcptError("spp values must be >= 1")
    real = {}
    if args.real is not None:
        from pathlib import Path

        from ..evaluation.scenes import evaluation_folder_names
        from ..dataset.real import real_scene_files
        if args.test:
            raise GmcptError("--real builds train and val splits only (--test 0): evaluation scenes are never trained on")
        real = dict(layout="real", real_root=str(Path(args.real).resolve()),
                    real_files=real_scene_files(args.real, evaluation_folder_names()))
    return DatasetSpec(splits=tuple(s for s in splits if s.count > 0), spp=args.spp,
                       rate_range=tuple(args.rate), **real)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt dataset``; returns the exit status."""
    # a terminated build stops its workers too (the `finally` in build); it resumes later
    handlers = interrupts.install()
    try:
        args = build_parser().parse_args(argv)
        spec = spec_from_args(args)
        if args.ray is not None:
            from ..runtime.cluster import check_address, check_reachable
            check_reachable(check_address(args.ray))
        import gmcpt  # noqa: F401
        from ..dataset.build import build
        summary = build(args.out, spec, workers=args.workers, threads=args.threads, ray=args.ray, quiet=args.quiet)
        print(json.dumps(summary))
        return 0
    except (GmcptError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, interrupts.Terminated) as error:
        return interrupts.report(error)
    finally:
        interrupts.restore(handlers)


if __name__ == "__main__":
    sys.exit(main())
