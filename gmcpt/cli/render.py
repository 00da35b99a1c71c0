"""``gmcpt render``: path trace a fraction of a scene's pixels, complete the image, write EXR + PNG + JSON.

    gmcpt render SCENE.xml --out OUT.exr [options]
    gmcpt SCENE.xml --out OUT.exr [options]        (the same: a scene file first means render)

The output's folder is created if its parent exists, as ``gmcpt batch`` does.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Callable

from ..completion.tiles import MIN_TILE
from ..errors import GmcptError
from ..frame import DEFAULT_FEATURE_SPP
from ..runtime import interrupts
from ..runtime.device import DEVICE_ENV, PRECISION_ENV, completion_device, generator_precision
from .command import Parser, mitsuba_command, stamped_say

DESCRIPTION = "Path trace a fraction of the pixels of a Mitsuba 3 scene and complete the image."


def add_render_options(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The options of one render (all but the scene, --out and --reference), shared with batch."""
    parser.add_argument("--rate", type=float, help="fraction of pixels to path trace, in (0, 1], each at --spp "
                        "(default: the scene's, else a budget; 0.3 with --spp or another --mask)")
    parser.add_argument("--spp", type=int, help="samples per traced pixel (default: the scene's sampler)")
    parser.add_argument("--budget", type=float, metavar="B", help="mean path samples a pixel instead of --rate and "
                        "--spp: each frame's first pass chooses between B/16 of the pixels at 16 spp and all of "
                        "them; without a rate, an spp or another mask (default: the scene's, else 0.3 x the scene's spp)")
    parser.add_argument("--time", type=float, metavar="S", help="seconds of wall time for the frame and its "
                        "completion, instead of --rate, --spp and --budget: every pixel traced, in passes sized to "
                        "fill S (default: the scene's, else none)")
    parser.add_argument("--costs", metavar="FILE", help="the cost model a budget's choice weighs time with: a costs "
                        "file or a render's JSON, whose model it replays; the same options and model give the same "
                        "image on any machine (default: the scene's, else this machine's, measured once and stored)")
    parser.add_argument("--seed", type=int, help="seed of the mask and the samplers (default: the scene's, else 0)")
    parser.add_argument("--mask", help="sample placement: two_pass, adaptive, random, stratified, blue_noise "
                        "(default: the scene's, else two_pass)")
    parser.add_argument("--method", help="completion method, see gmcpt methods (default: the scene's, else gan_oidn)")
    parser.add_argument("--weights", help="generator of the GAN methods: a shipped name or a .pt file "
                        "(default: the scene's, else gan-cpu)")
    parser.add_argument("--tile", type=int, metavar="N", help=f"complete frames larger than N x N in blended tiles "
                        f"(bounded memory), N >= {MIN_TILE}; 0: whole (default: the scene's, else 1024)")
    parser.add_argument("--res", type=int, nargs=2, metavar=("W", "H"),
                        help="film resolution (default: the scene's)")
    parser.add_argument("--feature-spp", type=int, help=f"primary samples per pixel of the feature pass "
                        f"(default: the scene's, else {DEFAULT_FEATURE_SPP})")
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                        help="set a scene parameter ($NAME in the XML); repeatable (default: none)")
    parser.add_argument("--allow-nonfinite", action="store_true",
                        help="drop NaN/Inf samples with a warning instead of failing")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress messages")
    return parser


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("render", DESCRIPTION)
    parser.add_argument("scene", help="Mitsuba 3 scene XML (any integrator; masked_path wraps it)")
    parser.add_argument("--out", required=True, help="output EXR (required); OUT.png and OUT.json go beside it, "
                        "its folder is created if its parent exists")
    parser.add_argument("--reference", help="reference EXR (gmcpt reference makes one): adds MSE, PSNR, SSIM, "
                        "FLIP and relMSE to the JSON (default: none)")
    return add_render_options(parser)


def validate(args) -> None:
    """Every check on the command line's own values, before any work (the scene's are checked once loaded)."""
    from ..sampling.budget import check_budget
    from ..completion import check_options
    from ..sampling.costs import read_costs
    from ..io.files import check_not_inputs, check_output
    from ..gan.names import weights_path
    from ..limits import check_feature_spp, check_resolution, check_seconds, check_seed, check_spp
    from ..completion.tiles import check_tile
    from ..sampling.masks import check_pattern, check_rate
    from ..sampling.strategies import check_one_sample_count
    from ..render.scene import check_scene_file, scene_inputs

    if not args.out.lower().endswith(".exr"):
        raise GmcptError(f"--out must name an .exr file, got {args.out}")
    for path in _outputs(args.out):
        check_output(path)
    if args.rate is not None:
        check_rate(args.rate)
    if args.budget is not None:
        check_budget(args.budget, "--budget")
    if args.time is not None:
        check_seconds(args.time, "--time")
    if args.costs is not None:
        read_costs(args.costs)
    check_one_sample_count({name: f"--{name}" for name in ("rate", "spp", "budget", "time")},
                           rate=args.rate, spp=args.spp, budget=args.budget, time=args.time)
    if args.tile is not None:
        check_tile(args.tile)
    if args.spp is not None:
        check_spp(args.spp, "--spp")
    if args.feature_spp is not None:
        check_feature_spp(args.feature_spp, "--feature-spp")
    if args.seed is not None:
        check_seed(args.seed, "--seed")
    if args.mask is not None:
        check_pattern(args.mask)
    if args.res is not None:
        check_resolution(*args.res, args.feature_spp or DEFAULT_FEATURE_SPP, "--res")
    for define in args.defines:
        if "=" not in define:
            raise GmcptError(f"-D expects NAME=VALUE, got {define!r}")
    weights = [weights_path(args.weights)] if args.weights else []
    check_not_inputs(_outputs(args.out), {"scene file": scene_inputs(args.scene), "weights file": weights,
                                          "weights record": [path.with_suffix(".json") for path in weights],
                                          "reference": [args.reference] if args.reference else []})
    check_scene_file(args.scene)  # before the weights load torch: a missing scene is said at once
    check_options(args.method, args.weights)


def _weights_record(integrator) -> dict:
    """The GAN weights a method used (name and sha256) and the generator's arithmetic, or nothing for the
    methods without a network."""
    from ..completion import get_method
    from ..gan.names import DEFAULT_WEIGHTS, checked_weights

    if not get_method(integrator.completion).takes("weights"):
        return {}
    name = integrator.weights or DEFAULT_WEIGHTS
    return {"weights": name, "weights_sha256": checked_weights(name)[1].get("sha256"),
            "generator_precision": generator_precision(completion_device())}


def read_reference(path: str):
    """The reference image, refused (one line) if metrics against it would be NaN."""
    from ..io.exr import read_rgb_exr
    from ..image.metrics import check_reference

    reference = read_rgb_exr(path)
    try:
        return check_reference(reference)
    except GmcptError as error:
        raise GmcptError(f"reference {path}: {error}") from None


def _outputs(out: str):
    from ..io.outputs import sidecar_paths
    return sidecar_paths(out)


def check_nonfinite(dropped: int, allow: bool) -> None:
    """``dropped`` NaN/Inf radiance samples: one-line error, or with ``allow`` (``--allow-nonfinite``) a warning."""
    if dropped:
        message = f"{dropped} radiance samples were NaN/Inf"
        if not allow:
            raise GmcptError(message + " (broken scene data?); --allow-nonfinite drops them and goes on")
        print(f"warning: {message}; dropped them", file=sys.stderr)


def run(args, say=lambda message: None, extra: dict | None = None,
        committed: Callable[[], None] | None = None) -> dict:
    """Render, complete and write; returns the JSON record (``extra`` entries added to it).

    ``committed`` runs as soon as the three outputs are in place (:func:`gmcpt.io.files.write_together`).
    """
    from ..completion import check_size
    from ..limits import check_resolution
    from ..image.metrics import all_metrics
    from ..io.files import make_folder
    from ..io.outputs import library_versions, write_outputs
    from ..render.scene import load_scene, masked_integrator, scene_sensor

    started = time.perf_counter()
    validate(args)
    reference = read_reference(args.reference) if args.reference else None
    parameters = dict(define.split("=", 1) for define in args.defines)
    scene = load_scene(args.scene, tuple(args.res) if args.res else None, parameters)
    # --rate/--spp drop a budget or a time the scene sets, and each of --budget and --time the other
    fixed = args.rate or args.spp
    budget = args.budget if args.budget is not None else (0.0 if fixed or args.time else None)
    seconds = args.time if args.time is not None else (0.0 if fixed or args.budget else None)
    integrator = masked_integrator(scene, rate=args.rate, budget=budget, time=seconds, mask=args.mask, seed=args.seed,
                                   feature_spp=args.feature_spp, completion=args.method, weights=args.weights,
                                   tile=args.tile, costs=args.costs)
    # every check on the input happens before the first progress line (render_sparse_frame checks the
    # scene's own resolution and spp before its first one)
    size = scene_sensor(scene, path=args.scene).film().crop_size()
    width, height = int(size[0]), int(size[1])
    check_resolution(width, height, integrator.feature_spp)
    check_size(integrator.completion, height, width)
    if os.environ.get(DEVICE_ENV):  # a device asked for by name must exist before the render starts
        completion_device()
    if os.environ.get(PRECISION_ENV):  # and a precision asked for must be one
        generator_precision("cpu")
    if reference is not None and reference.shape != (height, width, 3):
        raise GmcptError(f"reference {args.reference} is {reference.shape[1]}x{reference.shape[0]}, "
                         f"the render is {width}x{height}")
    sensor = scene_sensor(scene, path=args.scene)
    settings = integrator.settings(spp=args.spp or 0, sensor=sensor)

    def check(frame) -> None:
        check_nonfinite(frame.info.nonfinite_samples, args.allow_nonfinite)
        if frame.info.time_short:
            print(f"warning: --time {settings.time:g} s is less than one sample a pixel and the completion cost "
                  "here; rendered one sample a pixel", file=sys.stderr)

    result = integrator.render_frame(scene, sensor, spp=args.spp or 0, progress=say, check=check)
    frame, timings = result.frame, result.timings
    record = {
        "scene": str(Path(args.scene).resolve()),
        "output": str(Path(args.out).resolve()),
        # with a budget the frame's rate is the chooser's: rendered_fraction below
        "parameters": {"rate": None if settings.budget or settings.time else settings.rate,
                       "budget": settings.budget or None, "time": settings.time or None,
                       "mask": settings.pattern, "seed": settings.seed, "spp": frame.spp,
                       "feature_spp": settings.feature_spp, "method": integrator.completion,
                       # the weights where the generator ran: loading them for the record alone took 5-6 s of a
                       # dense frame's process, importing torch
                       "tile": integrator.tile, **(_weights_record(integrator) if "load_weights_s" in timings else {}),
                       # completion imports torch only for the methods that run on it
                       "device": completion_device() if "torch" in sys.modules else "cpu",
                       "resolution": [width, height], "scene_parameters": parameters,
                       "integrator": " ".join(str(integrator.integrator).split())},
        "versions": library_versions(),
        "rendered_fraction": frame.rendered_fraction,
        **frame.info.to_json(),
        "timings": timings,
    }
    if reference is not None:
        say("computing metrics against the reference")
        record["reference"] = str(Path(args.reference).resolve())
        record["metrics"] = all_metrics(result.image, reference)
    record.update(extra or {})
    timings["total_s"] = time.perf_counter() - started
    make_folder(args.out)
    written = write_outputs(args.out, frame, result.image, record, committed)
    say("wrote " + ", ".join(str(p) for p in written))
    return record


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt render``; returns the exit status."""
    def work(args) -> int:
        say = stamped_say("gmcpt", args.quiet)
        record = run(args, say, committed=interrupts.settle)
        if "metrics" in record:
            m = record["metrics"]
            say(f"PSNR {m['psnr']:.2f} dB  SSIM {m['ssim']:.4f}  MSE {m['mse']:.3e}  relMSE {m['relmse']:.3e}  "
                f"FLIP {m['flip']:.4f}")
        return 0
    return mitsuba_command(sys.argv[1:] if argv is None else list(argv), build_parser, work)


if __name__ == "__main__":
    sys.exit(main())
