"""``gmcpt train``: train the GAN pre-completion and (optionally) export shipped weights.

    gmcpt train --config cpu --out runs/gan-cpu --export gan-cpu

Rerunning with the same ``--out`` resumes from its checkpoint; ``--export``
writes ``gmcpt/gan/weights/NAME.pt`` (or a ``.pt`` path) and its metadata JSON when
training ends; ``--minutes M`` ends it once M minutes of the command are spent (the
last step that fits is checkpointed and exported; rerunning resumes there).
``torchrun --nproc_per_node N -m gmcpt train ...`` trains on N processes
(:mod:`gmcpt.gan.distributed`); rank 0 logs, checkpoints and exports.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from ..errors import GmcptError
from .command import Parser


def build_parser() -> argparse.ArgumentParser:
    parser = Parser("train", "Train the GAN pre-completion and (optionally) export its weights.\n"
                    "Rerunning with the same --out resumes from its checkpoint.")
    parser.add_argument("--config", default="cpu", help="preset (cpu, gpu) or a JSON file")
    parser.add_argument("--out", help="run folder: checkpoint, curves.png, history.json (default: runs/gan-CONFIG)")
    parser.add_argument("--dataset", action="append", metavar="DIR",
                        help="dataset folder; repeat to pool several (default: the config's train.dataset)")
    parser.add_argument("--init", metavar="WEIGHTS",
                        help="start the generator from these weights (shipped name or .pt): fine-tune "
                        "(default: the config's train.init, else random)")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=JSON",
                        help="override a config value, e.g. train.steps=100; repeatable (default: none)")
    parser.add_argument("--export", metavar="NAME", help="write the trained generator to gmcpt/gan/weights/NAME.pt, "
                        "or to NAME if it is a .pt path (default: none)")
    parser.add_argument("--minutes", type=float, metavar="M",
                        help="stop after the last step that ends within M minutes of the start (default: no limit)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress")
    return parser


def _overrides(args) -> dict:
    overrides = {}
    for item in args.set:
        if "=" not in item or "." not in item.split("=", 1)[0]:
            raise GmcptError(f"--set expects SECTION.KEY=VALUE, got {item!r}")
        key, value = item.split("=", 1)
        try:
            overrides[key] = json.loads(value)
        except json.JSONDecodeError:
            overrides[key] = value
    if args.dataset:
        overrides["train.dataset"] = args.dataset[0] if len(args.dataset) == 1 else args.dataset
    if args.init:
        overrides["train.init"] = args.init
    return overrides


def export(trainer, name: str, command: str) -> dict:
    """Save the trainer's generator as shipped weights ``name`` (or to a ``.pt`` path) with full metadata."""
    from ..gan.weights import save_weights, weights_path

    records = []
    for dataset, seeds in zip(trainer.config.train.datasets, trainer.train_seeds):
        manifest_path = Path(dataset) / "manifest.json"
        manifest = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
        records.append({"path": str(dataset), "version": manifest.get("version"), "manifest": manifest,
                        "train_seeds": [min(seeds), max(seeds)], "train_scenes": len(seeds)})
    records[0]["val_seeds"] = [e["meta"]["seed"] for e in trainer.val]  # of all datasets, in order
    path = weights_path(name)
    metadata = {"name": path.stem, "command": command, "config": trainer.config.to_dict(),
                # one dataset: its record, as before; several: a list of them
                "dataset": records[0] if len(records) == 1 else records,
                "training": trainer.summary(), "created": time.strftime("%Y-%m-%dT%H:%M:%S")}
    return save_weights(path, trainer.generator, metadata)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``gmcpt train``; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    started = time.monotonic()
    try:
        args = build_parser().parse_args(argv)
        if args.minutes is not None and not args.minutes > 0:
            raise GmcptError(f"--minutes must be positive, got {args.minutes}")
        from ..gan.train import Trainer, load_config
        try:
            config = load_config(args.config, _overrides(args))
        except (OSError, ValueError, TypeError) as error:
            raise GmcptError(f"bad config {args.config}: {error}") from None
        out = Path(args.out or f"runs/gan-{Path(args.config).stem}")
        for dataset in config.train.datasets:
            if not (Path(dataset) / "train").is_dir():
                raise GmcptError(f"no dataset at {dataset}; build it with `python -m gmcpt dataset --out {dataset}`")
        if config.train.device.startswith("cuda"):
            import torch
            if not torch.cuda.is_available():
                raise GmcptError(f"the {config.train.device!r} device of config {args.config} is not here (torch sees "
                                 "no CUDA); use --config cpu or --set 'train.device=\"cpu\"'")
        from ..gan.distributed import from_environment, stop
        try:
            ranks = from_environment()
        except ValueError as error:
            raise GmcptError(str(error)) from None
        from .command import stamped_say
        say = stamped_say("train", args.quiet)
        try:
            trainer = Trainer(config, out, say, ranks=ranks, quiet=args.quiet)
            summary = trainer.run(None if args.minutes is None else started + 60 * args.minutes)
        except ValueError as error:  # incomplete dataset, a checkpoint from another config
            raise GmcptError(str(error)) from None
        finally:
            stop(ranks)
        if not ranks.main:
            return 0
        if args.export:
            record = export(trainer, args.export, "python -m gmcpt train " + " ".join(argv))
            summary["exported"] = {"file": record["file"], "sha256": record["sha256"], "bytes": record["bytes"]}
        print(json.dumps(summary))
        return 0
    except GmcptError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
