"""``gmcpt regress DIR``: check a suite of scenes against its goldens.

    gmcpt regress DIR [--scene NAME ...] [--seed N] [--report OUT.html]
    gmcpt regress DIR --update [--golden-spp N] [--rate R] [--spp S] [--seeds N] [--res W H]

Exit status: 0 when every scene passes, 1 when any regressed, 2 on bad input
(one ``error: ...`` line on stderr, nothing written). A check's time covers
loading the scene, rendering and completing it; the first render of a new or
changed scene also compiles its kernels (Dr.Jit caches them on disk; about
1.5 s for the Cornell box).
"""
from __future__ import annotations

import argparse
import sys

from ..errors import GmcptError
from ..regress.manifest import Settings
from .command import Parser, mitsuba_command

EXIT_PASS, EXIT_REGRESSED = 0, 1


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("regress", "Check scenes against golden images with cheap masked renders and completion.\n"
                    "Exit status: 0 every scene passes, 1 one regressed, 2 bad input.")
    parser.add_argument("folder", metavar="DIR",
                        help="suite folder: scenes NAME.xml or NAME/scene.xml, goldens in DIR/golden")
    parser.add_argument("--scene", action="append", default=[], metavar="NAME",
                        help="only this scene; repeatable (default: every scene)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the check's mask and samplers")
    parser.add_argument("--report", metavar="OUT.html", help="write an HTML report, images embedded (default: none)")
    parser.add_argument("--update", action="store_true",
                        help="render the goldens and set each scene's thresholds from the check's spread")
    group = parser.add_argument_group("with --update")
    default = Settings()
    prior = "(default: the manifest's, else {})".format
    group.add_argument("--golden-spp", type=int, help="samples per pixel of the goldens " + prior(default.golden_spp))
    group.add_argument("--rate", type=float, help="fraction of pixels the check traces " + prior(default.rate))
    group.add_argument("--spp", type=int, help="samples per traced pixel of the check " + prior(default.spp))
    group.add_argument("--method", help="completion method of the check " + prior(default.method))
    group.add_argument("--seeds", type=int, help="seeds the thresholds are calibrated on " + prior(default.seeds))
    group.add_argument("--res", type=int, nargs=2, metavar=("W", "H"),
                       help="render every scene at W x H " + prior("the scene's"))
    return parser


def _check_arguments(args) -> None:
    from ..completion import get_method
    from ..io.files import check_writable
    from ..sampling.masks import check_rate

    settings_flags = ("golden_spp", "rate", "spp", "method", "seeds", "res")
    if not args.update:
        given = [f"--{flag.replace('_', '-')}" for flag in settings_flags if getattr(args, flag) is not None]
        if given:
            raise GmcptError(f"{', '.join(given)}: only with --update (a check uses the manifest's settings)")
    if args.rate is not None:
        check_rate(args.rate)
    if args.method is not None:
        get_method(args.method)
    if args.res is not None and min(args.res) < 1:
        raise GmcptError(f"--res must be positive, got {args.res[0]} {args.res[1]}")
    if args.report:
        if args.update:
            raise GmcptError("--report goes with a check, not with --update")
        if not args.report.lower().endswith((".html", ".htm")):
            raise GmcptError(f"--report must name an .html file, got {args.report}")
        check_writable(args.report)


def run(args, out=print) -> int:
    """Run the parsed command; returns the exit status. Raises GmcptError on bad input."""
    from ..regress.manifest import load_suite, with_settings
    from ..regress.report import scene_line, summary, write_html
    from ..regress.run import check_suite, update_suite

    _check_arguments(args)
    suite = load_suite(args.folder)
    if args.update:
        settings = with_settings(suite, golden_spp=args.golden_spp, rate=args.rate, spp=args.spp, method=args.method,
                                 seeds=args.seeds, resolution=tuple(args.res) if args.res else None)
        goldens = update_suite(suite, settings, args.scene, say=out)
        out(f"wrote {len(goldens)} golden(s) and {suite.manifest_path}")
        return EXIT_PASS
    width = max([len(name) for name in suite.names()] + [8])
    results = check_suite(suite, args.scene, args.seed, on_result=lambda result: out(scene_line(result, width)))
    if args.report:
        write_html(args.report, results, title=f"gmcpt regress {args.folder}")
    out(summary(results, args.report))
    return EXIT_REGRESSED if any(not r.passed and not r.skipped for r in results) else EXIT_PASS


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt regress``; returns the exit status."""
    return mitsuba_command(sys.argv[1:] if argv is None else list(argv), build_parser,
                           lambda args: run(args, out=lambda line: print(line, flush=True)))


if __name__ == "__main__":
    sys.exit(main())
