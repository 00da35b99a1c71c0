"""``gmcpt methods``: the completion methods (``--method``) and sample placements (``--mask``), one line each."""
from __future__ import annotations

import sys

from .command import Parser, exit_status

#: what each placement of :data:`gmcpt.sampling.masks.PATTERNS` does, for the listing
PLACEMENTS = {
    "two_pass": "half at feature-buffer edges, half where those samples disagree with their neighbours (default)",
    "adaptive": "all at feature-buffer edges",
    "random": "uniformly random pixels (the paper's)",
    "stratified": "one jittered pixel per stratum of a Z-order curve: evenly, no clumps",
    "blue_noise": "high-passed white noise: evenly, no low-frequency clumps",
}


def listing() -> str:
    from ..completion import get_method, methods
    from ..sampling.masks import PATTERNS

    width = max(map(len, [*methods(), *PATTERNS]))
    lines = ["completion methods (--method):"]
    lines += [f"  {name:<{width}}  {get_method(name).summary}" for name in methods()]
    lines += ["sample placements (--mask):"]
    lines += [f"  {name:<{width}}  {PLACEMENTS[name]}" for name in PATTERNS]
    lines += ["or --budget B: B samples a pixel; a two_pass first pass chooses B/16 of the pixels at 16 spp "
              "(sparse) or every pixel (dense)"]
    return "\n".join(lines)


def build_parser() -> Parser:
    return Parser("methods", "List the completion methods (--method) and the sample placements (--mask).")


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt methods``; returns the exit status."""
    def body() -> int:
        build_parser().parse_args(sys.argv[1:] if argv is None else argv)
        print(listing())
        return 0
    return exit_status(body)


if __name__ == "__main__":
    sys.exit(main())
