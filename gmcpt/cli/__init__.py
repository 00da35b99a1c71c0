"""``gmcpt``: one command, its subcommands each a module with a ``main(argv)``.

    gmcpt SUBCOMMAND [options]          gmcpt SUBCOMMAND --help
    gmcpt SCENE.xml --out OUT.exr ...   (a scene file first means ``gmcpt render``)

``python -m gmcpt`` and ``render_and_complete.py`` are the same command. The
table below is the only list of subcommands: ``--help`` prints it, and a name
not in it is refused in one line (exit 2).

Every entry point lives in this folder, ``gmcpt.cli.NAME`` for ``gmcpt NAME`` (``eval``: :mod:`gmcpt.cli.eval`;
``train``: :mod:`gmcpt.cli.train`), with what they share (:mod:`gmcpt.cli.command`) and what ``batch`` runs
(:mod:`gmcpt.cli.batch_records`, :mod:`gmcpt.cli.sequence_batch`, :mod:`gmcpt.cli.sequence_ray`). The top
layer: it imports the others, and none imports it (docs/design.md, "Layers").
"""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

from ..runtime import interrupts
from .command import EXIT_BAD_INPUT

#: name -> (module, one line for ``gmcpt --help``)
SUBCOMMANDS = {
    "render": ("gmcpt.cli.render", "path trace a fraction of a scene's pixels, complete the image (EXR, PNG, JSON)"),
    "reference": ("gmcpt.cli.reference", "render a converged reference EXR of a scene at N spp"),
    "compare": ("gmcpt.cli.compare", "does the default pay off on your scene? equal samples and equal time"),
    "batch": ("gmcpt.cli.batch", "render many scenes, frames (--frames) or parameter sweeps, here or on Ray"),
    "regress": ("gmcpt.cli.regress", "check a folder of scenes against its golden images"),
    "eval": ("gmcpt.cli.eval", "measure the methods, rewrite docs/results.md and the README's results"),
    "dataset": ("gmcpt.cli.dataset", "render the procedural training data of the GAN"),
    "train": ("gmcpt.cli.train", "train the GAN pre-completion and export its weights"),
    "methods": ("gmcpt.cli.methods", "list the completion methods and the sample placements"),
}
DEFAULT = "render"


def usage() -> str:
    width = max(map(len, SUBCOMMANDS))
    lines = ["usage: gmcpt SUBCOMMAND [options]   (gmcpt SUBCOMMAND --help for its options)", "",
             "Sparse path tracing in Mitsuba 3 with GAN + matrix completion.", "", "subcommands:"]
    lines += [f"  {name:<{width}}  {summary}" for name, (_, summary) in SUBCOMMANDS.items()]
    lines += ["", "A scene file as the first argument means render: gmcpt SCENE.xml --out OUT.exr"]
    return "\n".join(lines)


def subcommand(argv: list[str]) -> tuple[str | None, list[str]]:
    """(subcommand, its arguments); None for a first argument that is neither a subcommand nor a scene."""
    if argv and argv[0] in SUBCOMMANDS:
        return argv[0], argv[1:]
    if argv and (argv[0].lower().endswith(".xml") or argv[0].startswith("-") or Path(argv[0]).exists()):
        return DEFAULT, argv  # a scene file (any name) or options first, as before; a folder, render refuses
    return None, argv


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt``; returns the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(usage(), file=sys.stdout if argv else sys.stderr)
        return 0 if argv else EXIT_BAD_INPUT
    name, rest = subcommand(argv)
    if name is None:
        print(f"error: unknown subcommand {argv[0]!r}; choose from {', '.join(SUBCOMMANDS)} "
              f"(or give a scene file)", file=sys.stderr)
        return EXIT_BAD_INPUT
    if interrupts.startup_error is not None and not {"-h", "--help"} & set(rest):  # help needs no variant
        print(f"error: {interrupts.startup_error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    return importlib.import_module(SUBCOMMANDS[name][0]).main(rest)
