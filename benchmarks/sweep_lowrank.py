"""Parameter sweep for the low-rank completion (PAWNNM), printed as a ranked table.

Frames come from ``.npz`` files (arrays ``reference``, ``observed``, ``mask``,
``pre_completed``, optionally ``variance`` and ``guide``, all in the working
domain) or, by default, from the synthetic generator of
``completion_speed.py``.  Every combination of the grid is run on every
frame; rows are ranked by mean PSNR against the reference (working domain,
peak ``--peak``) and show the mean time per frame.

    python benchmarks/sweep_lowrank.py                         # default grid, 2 synthetic frames
    python benchmarks/sweep_lowrank.py --w0 1e4 3e4 1e5 --iterations 8 16 \\
        --patch 7:3 9:4 --K 12 16 --data-term exact soft
    python benchmarks/sweep_lowrank.py --grid c=0.8,0.9 rematch_every=2,4 --set tile_size=None
    python benchmarks/sweep_lowrank.py --npz frames/*.npz --set feature_weight=0.5

From Python, ``sweep(frames, grid)`` takes any iterable of such dicts (for
example a loader of rendered frames) and returns the rows.
"""
from __future__ import annotations

import argparse
import ast
import itertools
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from completion_speed import psnr, synthetic_frame  # noqa: E402


def load_npz(path) -> dict:
    """One frame from an ``.npz`` file (see the module docstring)."""
    with np.load(path) as z:
        frame = {k: z[k] for k in z.files}
    missing = {"reference", "observed", "mask", "pre_completed"} - frame.keys()
    if missing:
        raise ValueError(f"{path}: missing arrays {sorted(missing)}")
    frame["mask"] = frame["mask"].astype(bool)
    frame.setdefault("name", Path(path).stem)
    return frame


def sweep(frames, grid: dict, *, base=None, peak: float = 255.0, verbose: bool = True):
    """Run every combination of ``grid`` (field name -> list of values) on every frame.

    Returns a list of dicts ``{"params": {...}, "psnr": [...], "time": [...]}``
    sorted by mean PSNR, best first.
    """
    from gmcpt.lowrank import DEFAULT, complete_low_rank

    base = DEFAULT if base is None else base
    frames = list(frames)
    keys = list(grid)
    rows = []
    combos = list(itertools.product(*(grid[k] for k in keys)))
    for i, values in enumerate(combos):
        setting = dict(zip(keys, values))
        if "patch" in setting:
            p, s = setting.pop("patch")
            setting.update(patch_size=p, step=s)
        try:
            prm = replace(base, **setting)
        except ValueError as err:
            if verbose:
                print(f"  skip {setting}: {err}", flush=True)
            continue
        scores, times = [], []
        for fr in frames:
            needs_var = prm.data_term == "soft" and prm.soft_delta is None
            if needs_var and fr.get("variance") is None:
                break
            t0 = time.perf_counter()
            out, _ = complete_low_rank(fr["pre_completed"], fr["observed"], fr["mask"],
                                       variance=fr.get("variance"), guide=fr.get("guide"),
                                       params=prm)
            times.append(time.perf_counter() - t0)
            scores.append(psnr(out, fr["reference"], peak))
        else:
            rows.append(dict(params=setting, psnr=scores, time=times))
            if verbose:
                print(f"  [{i + 1}/{len(combos)}] {setting}: {np.mean(scores):.2f} dB, "
                      f"{np.mean(times):.2f} s", flush=True)
    rows.sort(key=lambda r: -np.mean(r["psnr"]))
    return rows


def _value(text: str):
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--npz", nargs="*", default=[], help="frames as .npz files")
    ap.add_argument("--synthetic", type=int, default=2, help="number of synthetic frames (seeds)")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--rate", type=float, default=0.3)
    ap.add_argument("--noise", type=float, default=12.0)
    ap.add_argument("--w0", type=float, nargs="+", default=[2e4, 3e4, 5e4])
    ap.add_argument("--iterations", type=int, nargs="+", default=[11, 15])
    ap.add_argument("--patch", nargs="+", default=["7:5", "7:4"], help="patch_size:step pairs")
    ap.add_argument("--K", type=int, nargs="+", default=[16, 24])
    ap.add_argument("--data-term", nargs="+", default=["exact", "soft"])
    ap.add_argument("--grid", nargs="*", default=[], metavar="FIELD=V1,V2,...",
                    help="more swept fields, e.g. c=0.8,0.9 rematch_every=2,4")
    ap.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                    help="fixed overrides of DEFAULT, e.g. rematch_every=4 threshold='constant'")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--peak", type=float, default=255.0)
    ap.add_argument("--top", type=int, default=20)
    args = ap.parse_args(argv)

    import torch
    from gmcpt.lowrank import DEFAULT

    torch.set_num_threads(args.threads)
    if args.npz:
        frames = [load_npz(p) for p in args.npz]
    else:
        frames = [dict(synthetic_frame(args.size, rate=args.rate, noise=args.noise, seed=s),
                       name=f"synthetic{s}") for s in range(args.synthetic)]
    base = replace(DEFAULT, **{k: _value(v) for k, v in (kv.split("=", 1) for kv in args.set)})
    grid = {"w0": args.w0, "iterations": args.iterations,
            "patch": [tuple(int(v) for v in ps.split(":")) for ps in args.patch],
            "group_size": args.K, "data_term": args.data_term}
    for kv in args.grid:
        key, vals = kv.split("=", 1)
        grid[key] = [_value(v) for v in vals.split(",")]
    pre = [psnr(f["pre_completed"], f["reference"], args.peak) for f in frames]
    print(f"{len(frames)} frame(s): {', '.join(f.get('name', '?') for f in frames)}; "
          f"pre-completion {np.mean(pre):.2f} dB; {args.threads} threads", flush=True)
    print(f"base: {base}", flush=True)
    rows = sweep(frames, grid, base=base, peak=args.peak)
    print()
    print("| rank | " + " | ".join(grid) + " | PSNR dB | gain dB | time s |")
    print("|---" * (len(grid) + 4) + "|")
    for i, r in enumerate(rows[: args.top]):
        prm = r["params"]
        cells = [f"{prm.get('patch_size')}:{prm.get('step')}" if k == "patch" else str(prm.get(k))
                 for k in grid]
        print(f"| {i + 1} | " + " | ".join(cells)
              + f" | {np.mean(r['psnr']):.2f} | {np.mean(r['psnr']) - np.mean(pre):+.2f}"
              f" | {np.mean(r['time']):.2f} |", flush=True)


if __name__ == "__main__":
    main()
