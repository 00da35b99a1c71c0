"""Markdown tables and the crossover analysis, as pure functions of an evaluation's rows."""
from __future__ import annotations

import numpy as np

from .config import VARIANTS, patch_variant

#: Equal-time budgets in units of the scene's 1-spp full-frame render time.
TIME_BUDGETS = (1, 2, 4, 8, 16, 32, 64, 128, 256, 512)
#: Equal-sample budgets (path samples per pixel, rate x spp for the completion methods).
SAMPLE_BUDGETS = (0.125, 0.25, 0.5, 1, 2, 4, 8, 16, 32, 64)
CONTENDER_NAMES = {"path": "path tracing", "path+oidn": "path tracing + OIDN",
                   "adaptive+oidn": "adaptive path tracing + OIDN"}
#: the baselines the default is held against (docs/design.md section 6)
BASELINES = ("path+oidn", "adaptive+oidn")


def contender_name(label: str) -> str:
    return CONTENDER_NAMES.get(label, label)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return "\n".join(lines + ["| " + " | ".join(row) + " |" for row in rows])


def row_scenes(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(row["scene"] for row in rows))


def _mean(rows: list[dict], key: str, **where) -> float | None:
    chosen = [row[key] for row in rows if all(row.get(k) == v for k, v in where.items())]
    return float(np.mean(chosen)) if chosen else None


def groups(rows: list[dict]) -> list[tuple[str, dict]]:
    """(label, filter) of each scene, then of the mean over the real scenes and over the synthetic ones (where
    there are both), then of the mean over all; a filter is ``where`` for :func:`_mean`."""
    scenes = row_scenes(rows)
    real = [scene for scene in scenes if any(r["scene"] == scene and r.get("real") for r in rows)]
    out = [(scene, {"scene": scene}) for scene in scenes]
    if real and len(real) < len(scenes):
        out += [(f"**mean of {len(real)} real**", {"real": True}),
                (f"**mean of {len(scenes) - len(real)} synthetic**", {"real": False})]
    return out + [(f"**mean of {len(scenes)}**", {})]


def equal_samples_lead(rows: list[dict], default: str, rate: float, **where) -> float | None:
    """The default's mean PSNR over the better of the two baselines' at equal samples (placement rows), on the
    rows that match ``where``; None where either is missing."""
    mine = _mean(rows, "psnr", variant=default, rate=rate, **where)
    theirs = [t for t in (_mean(rows, "psnr", variant=b, rate=rate, **where) for b in BASELINES) if t is not None]
    return None if mine is None or not theirs else mine - max(theirs)


def in_group(rows: list[dict], where: dict) -> list[str]:
    """The scenes of one group."""
    return [s for s in row_scenes(rows) if any(r["scene"] == s and all(r.get(k) == v for k, v in where.items())
                                            for r in rows)]


def _per_scene_and_mean(rows, rates, cell) -> list[list[str]]:
    """Rows (group, rate, cells...) for each scene and the means (:func:`groups`); ``cell(where, rate)``."""
    return [[label, f"{rate:.0%}", *cell(where, rate)] for label, where in groups(rows) for rate in rates]


def _cells(rows, variants, metrics, where, rate):
    formats = {"psnr": 2, "ssim": 3, "mse": -1, "flip": 3, "relmse": -1}
    out = []
    for variant in variants:
        for metric in metrics:
            digits = formats[metric]
            value = _mean(rows, metric, variant=variant, rate=rate, **where)
            out.append("-" if value is None else (f"{value:.1e}" if digits < 0 else f"{value:.{digits}f}"))
    return out


def variant_table(rows: list[dict], variants: list[str], metrics: list[str], rates, deltas=()) -> str:
    """Per scene and rate, ``metrics`` of each variant; each pair ``(a, b)`` of ``deltas`` adds PSNR(a) - PSNR(b)."""
    variants = [v for v in variants if any(row["variant"] == v for row in rows)]
    pairs = [pair for pair in deltas if all(any(row["variant"] == v for row in rows) for v in pair)]
    header = ["scene", "rate"] + [f"{v} {m.upper() if m != 'psnr' else 'PSNR dB'}" for v in variants for m in metrics]
    header += [f"{a} - {b} dB" for a, b in pairs]

    def cell(where, rate):
        cells = _cells(rows, variants, metrics, where, rate)
        for pair in pairs:
            a, b = (_mean(rows, "psnr", variant=v, rate=rate, **where) for v in pair)
            cells.append("-" if a is None or b is None else f"{a - b:+.2f}")
        return cells

    return markdown_table(header, _per_scene_and_mean(rows, rates, cell))


def patch_table(rows: list[dict], sizes, rates) -> str:
    """PSNR against patch size (paper Fig. 12)."""
    labels = [patch_variant(size).label for size in sizes]
    header = ["scene", "rate"] + [f"{size}x{size}" for size in sizes]
    table = _per_scene_and_mean([r for r in rows if r["variant"] in labels], rates,
                                lambda where, rate: _cells(rows, labels, ["psnr"], where, rate))
    return markdown_table(header, table)


def reference_table(noise_rows: list[dict]) -> str:
    return markdown_table(["scene", "reference spp", "PSNR dB vs second reference", "SSIM", "FLIP"],
                  [[r["scene"], str(r["reference_spp"]), f"{r['noise_psnr']:.2f}", f"{r['noise_ssim']:.4f}",
                    f"{r['noise_flip']:.4f}"] for r in noise_rows])


# --- equal time / equal samples -------------------------------------------------------------------------

def best_within(rows: list[dict], contender: str, axis: str, budget: float) -> dict | None:
    """The contender's highest-PSNR row whose ``axis`` (seconds or samples_per_pixel) fits ``budget``."""
    fitting = [r for r in rows if r["contender"] == contender and r[axis] <= budget * (1 + 1e-9)]
    return max(fitting, key=lambda r: r["psnr"]) if fitting else None


def contenders(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(row["contender"] for row in rows))


def one_spp_seconds(rows: list[dict], scene: str) -> float:
    return next(r["seconds"] for r in rows if r["scene"] == scene and r["contender"] == "path" and r["spp"] == 1)


def _setting(row: dict) -> str:
    if "budget_choice" in row:  # the budget chooser: rate x spp is its budget, and it chose its own way
        return f"budget {row['rate'] * row['spp']:g}, {row['budget_choice']}"
    return f"{row['spp']:g} spp" if row["rate"] == 1.0 else f"{row['rate']:g} x {row['spp']} spp"


def budget_table(rows: list[dict], axis: str) -> str:
    """Mean over scenes and per scene, the best PSNR / SSIM / FLIP of each contender within each budget.

    A budget whose row would repeat the previous one (nothing better fits) is left out.

    ``axis="seconds"``: budgets are multiples of each scene's 1-spp render
    time; ``axis="samples_per_pixel"``: budgets in path samples per pixel.
    """
    names = contenders(rows)
    budgets = TIME_BUDGETS if axis == "seconds" else SAMPLE_BUDGETS
    unit = "x 1-spp time" if axis == "seconds" else "samples / pixel"
    header = ["scene", f"budget ({unit})"] + [contender_name(c) for c in names]
    table = []
    for label, where in groups(rows):
        scenes = in_group(rows, where)
        for budget in budgets:
            cells = []
            for name in names:
                best = [best_within([r for r in rows if r["scene"] == s], name, axis,
                                    budget * (one_spp_seconds(rows, s) if axis == "seconds" else 1)) for s in scenes]
                if any(b is None for b in best):
                    cells.append("-")
                elif "scene" in where:
                    b = best[0]
                    cells.append(f"{b['psnr']:.2f} / {b['ssim']:.3f} / {b['flip']:.3f} ({_setting(b)}, {b['seconds']:.2f} s)")
                else:
                    cells.append(" / ".join(f"{np.mean([b[m] for b in best]):.{d}f}"
                                            for m, d in (("psnr", 2), ("ssim", 3), ("flip", 3))))
            previous = table[-1] if table and table[-1][0] == label else None
            if any(c != "-" for c in cells) and (previous is None or previous[2:] != cells):
                table.append([label, f"{budget:g}", *cells])
    return markdown_table(header, table)


def crossover(rows: list[dict], scene: str, challenger: str, incumbent: str, axis: str) -> str:
    """Where ``challenger``'s best-within-budget PSNR beats ``incumbent``'s, over every measured budget."""
    scene_rows = [r for r in rows if r["scene"] == scene]
    budgets = sorted({r[axis] for r in scene_rows if r["contender"] in (challenger, incumbent)})
    unit = " s" if axis == "seconds" else " spp"
    fmt = (lambda v: f"{v:.2f}{unit}") if axis == "seconds" else (lambda v: f"{v:g}{unit}")
    alone, ahead, both = [], [], []
    for budget in budgets:
        a = best_within(scene_rows, challenger, axis, budget)
        b = best_within(scene_rows, incumbent, axis, budget)
        if a is None:
            continue
        if b is None:
            alone.append(budget)
            continue
        both.append(budget)
        if a["psnr"] > b["psnr"]:
            ahead.append(budget)
    name = contender_name(incumbent)
    parts = [f"below {fmt(both[0])} only {challenger} can run" if alone and both else ""]
    if not both:
        parts.append(f"{name} cannot run within any budget where {challenger} can")
    elif not ahead:
        parts.append(f"{challenger} is behind {name} at every budget from {fmt(both[0])} to {fmt(both[-1])}")
    elif ahead == both:
        parts.append(f"{challenger} is ahead of {name} at every budget from {fmt(both[0])} to {fmt(both[-1])}")
    elif ahead == both[:len(ahead)]:
        parts.append(f"{challenger} is ahead of {name} up to {fmt(ahead[-1])} and behind from {fmt(both[len(ahead)])}")
    elif ahead == both[-len(ahead):]:
        parts.append(f"{challenger} is behind {name} up to {fmt(both[-len(ahead) - 1])} and ahead from {fmt(ahead[0])}")
    else:
        parts.append(f"{challenger} is ahead of {name} at {len(ahead)} of {len(both)} budgets "
                     f"({', '.join(fmt(b) for b in ahead)})")
    return ", ".join(part for part in parts if part)


def crossover_lines(rows: list[dict]) -> list[str]:
    """One line per scene, challenger and axis: where each completion variant overtakes, or is overtaken."""
    lines = []
    challengers = [c for c in contenders(rows) if c not in CONTENDER_NAMES]
    for scene in row_scenes(rows):
        for axis, label in (("samples_per_pixel", "equal samples"), ("seconds", "equal time")):
            parts = [crossover(rows, scene, c, "path+oidn", axis) for c in challengers]
            lines.append(f"- {scene}, {label}: " + "; ".join(parts) + ".")
    return lines


def merged(rows: list[dict], label: str = "completion") -> list[dict]:
    """The rows with every completion variant relabelled ``label`` (their best setting then competes as one)."""
    return [r if r["contender"] in CONTENDER_NAMES else dict(r, contender=label) for r in rows]


def crossover_table(rows: list[dict]) -> str:
    """Per scene: where the best completion setting beats path tracing + OIDN at equal samples and at equal time,
    and the best each reaches at its smallest sample budgets (below 1 spp; 1 spp)."""
    rows = merged(rows)
    header = ["scene", "equal samples", "equal time", "best completion below 1 spp", "path tracing + OIDN at 1 spp"]
    table = []
    for scene in row_scenes(rows):
        scene_rows = [r for r in rows if r["scene"] == scene]
        below = best_within(scene_rows, "completion", "samples_per_pixel", 0.999)
        one = best_within(scene_rows, "path+oidn", "samples_per_pixel", 1.0)
        cell = lambda r: "-" if r is None else f"{r['psnr']:.2f} dB ({_setting(r)}, {r['seconds']:.2f} s)"  # noqa: E731
        table.append([scene, crossover(rows, scene, "completion", "path+oidn", "samples_per_pixel"),
                      crossover(rows, scene, "completion", "path+oidn", "seconds"), cell(below), cell(one)])
    return markdown_table(header, table)


def stage_table(rows: list[dict]) -> str:
    keys = ["features_s", "render_s", "pre_completion_s", "block_matching_s", "svd_s", "aggregation_s",
            "wiener_s", "denoise_s", "completion_s", "total_s"]
    header = ["resolution", "method", "features", "render", "pre-completion (the fill, or the GAN)",
              "block matching", "SVD", "aggregation", "Wiener pass", "OIDN", "completion (all)", "total"]
    return markdown_table(header, [[f"{r['resolution']}x{r['resolution']}", r["variant"],
                            *(f"{r.get(k, 0.0):.3f}" for k in keys)] for r in rows])


def variant_legend(labels: list[str]) -> str:
    return "\n".join(f"- `{label}`: {VARIANTS[label].summary}" for label in labels if label in VARIANTS)


# --- speed-up at equal quality ----------------------------------------------------------------------------

def time_to_reach(rows: list[dict], contender: str, psnr: float) -> tuple[str, float] | None:
    """Seconds ``contender`` needs for ``psnr`` on its frontier (the best PSNR within each time), interpolated
    linearly in log time between its two settings that bracket it: ``("=", s)``; ``(">", s)`` when even its
    slowest setting ``s`` falls short, ``("<", s)`` when its fastest setting ``s`` already does better."""
    points = sorted((r["seconds"], r["psnr"]) for r in rows if r["contender"] == contender)
    if not points:
        return None
    best, frontier = -np.inf, []
    for seconds, value in points:
        best = max(best, value)
        frontier.append((seconds, best))
    if frontier[0][1] >= psnr:
        return "<", frontier[0][0]
    for (t0, p0), (t1, p1) in zip(frontier, frontier[1:]):
        if p1 >= psnr > p0:
            return "=", float(np.exp(np.log(t0) + (psnr - p0) / (p1 - p0) * (np.log(t1) - np.log(t0))))
    return ">", frontier[-1][0]


def speedup(rows: list[dict], setting: dict, baseline: str) -> tuple[str, float] | None:
    """(bound, ratio): the time ``baseline`` needs for the PSNR of ``setting`` (a row of the default) over
    the default's time; above 1 the default is faster. ``bound`` as in :func:`time_to_reach`.

    Where the rows keep each timing round's seconds (``round_seconds``, :mod:`.measure`), the ratio is the median
    of the ratios of one round each (the lower of the two middle ones where their number is even), every baseline
    setting that missed a round counted at its own median: runs of one round ran minutes apart at most, so a pace
    that drifts slows both sides of a ratio alike."""
    mine = [r for r in rows if r["scene"] == setting["scene"] and r["contender"] == baseline]
    # Rows without round times (older results files) count as one round of their own seconds.
    rounds = ([(i, seconds) for i, seconds in enumerate(setting.get("round_seconds") or []) if seconds is not None]
              or [(None, setting["seconds"])])
    found = []
    for index, seconds in rounds:
        reached = time_to_reach([_in_round(r, index) for r in mine], baseline, setting["psnr"])
        if reached is None:
            return None
        found.append((reached[0], reached[1] / seconds))
    return sorted(found, key=lambda f: f[1])[(len(found) - 1) // 2]


def _in_round(row: dict, index: int | None) -> dict:
    """``row`` with its time in timing round ``index`` (its median where it did not run in that round, or where
    ``index`` is None)."""
    times = row.get("round_seconds") or []
    if index is None or index >= len(times) or times[index] is None:
        return row
    return dict(row, seconds=times[index])


def better_speedup(rows: list[dict], setting: dict, baselines=BASELINES) -> tuple[str, float] | None:
    """:func:`speedup` against whichever of ``baselines`` reaches the setting's PSNR soonest (the smaller ratio):
    the default is held against the better baseline. None where no baseline ran."""
    found = [f for f in (speedup(rows, setting, b) for b in baselines) if f is not None]
    return min(found, key=lambda f: f[1]) if found else None


def equal_time_verdict(rows: list[dict], default: str, baselines=BASELINES, scenes=None,
                       setting: tuple[float, int] | None = None) -> dict | None:
    """The equal-time verdict: the geometric mean, over every row of ``default`` (on ``scenes``, default all; at
    one ``(rate, spp)`` ``setting``, default all), of the time the better of ``baselines`` needs for its PSNR over
    the default's time (:func:`better_speedup`). Above 1 the default is faster. ``gmcpt compare``, the speed-up
    table and the README's limits all call this, so that they agree by construction.

    Returns ``{"speedup", "settings", "bounds", "ratios"}`` (``ratios``: each row's ``(bound, ratio)``;
    ``bounds``: how many are only bounds, ``<`` or ``>`` of :func:`time_to_reach`), or None where nothing was
    measured."""
    chosen = [r for r in rows if r["contender"] == default and (scenes is None or r["scene"] in scenes)
              and (setting is None or (r["rate"], r["spp"]) == tuple(setting))]
    found = [f for f in (better_speedup(rows, r, baselines) for r in chosen) if f is not None]
    if not found:
        return None
    return {"speedup": float(np.exp(np.mean([np.log(f[1]) for f in found]))), "settings": len(found),
            "bounds": sum(f[0] != "=" for f in found), "ratios": found}


def verdict_sentence(verdict: dict | None, default: str, over: str) -> str:
    """One line: which is faster at equal quality and by how much (``over``: what the mean runs over)."""
    if verdict is None:
        return "no verdict: no baseline ran"
    ratio = verdict["speedup"]
    count, total = verdict["bounds"], verdict["settings"]
    bounds = (f"; {count} of {total} ratio{'s' if total > 1 else ''} "
              f"{'are only bounds' if count > 1 else 'is only a bound'}") if count else ""
    if ratio >= 1:
        return (f"{default} is {ratio:.2f}x faster than the better baseline at equal quality "
                f"(geometric mean over {over}{bounds})")
    return (f"the better baseline is {1 / ratio:.2f}x faster than {default} at equal quality "
            f"(geometric mean over {over}{bounds})")


def _ratio(value: tuple[str, float] | None) -> str:
    if value is None:
        return "-"
    return {"=": "", "<": "<", ">": ">"}[value[0]] + f"{value[1]:.2f}x"


def verdict_cell(verdict: dict | None, single: bool) -> str:
    """A cell of the speed-up table: one scene's one setting keeps its bound sign, a mean counts its bounds."""
    if verdict is None:
        return "-"
    if single and verdict["settings"] == 1:
        return _ratio(verdict["ratios"][0])
    bounds = verdict["bounds"]
    return f"{verdict['speedup']:.2f}x" + (f" ({bounds} bound{'s' if bounds > 1 else ''})" if bounds else "")


def speedup_table(rows: list[dict], default: str) -> str:
    """Per scene and group mean, for each setting of ``default``: how much time each baseline, and the better of
    the two, needs to match its PSNR, as a multiple of the default's time (geometric means over scenes and, in the
    last column, over settings too: :func:`equal_time_verdict`; ``<``, ``>``, ``(n bounds)``: bounds)."""
    settings = list(dict.fromkeys((r["rate"], r["spp"]) for r in rows if r["contender"] == default))
    baselines = [b for b in BASELINES if any(r["contender"] == b for r in rows)]
    budgets = {(r["rate"], r["spp"]) for r in rows if r["contender"] == default and "budget_choice" in r}
    header = ["scene", "baseline"] + [f"budget {rate * spp:g}" if (rate, spp) in budgets else f"{rate:g} x {spp} spp"
                                      for rate, spp in settings] + ["all settings"]
    against = [(contender_name(b), (b,)) for b in baselines] + ([("the better of the two", tuple(baselines))]
                                                                 if len(baselines) > 1 else [])
    table = []
    for label, where in groups(rows):
        scenes = in_group(rows, where)
        for name, chosen in against:
            cells = [verdict_cell(equal_time_verdict(rows, default, chosen, scenes, setting), len(scenes) == 1)
                     for setting in settings]
            cells.append(verdict_cell(equal_time_verdict(rows, default, chosen, scenes), False))
            table.append([label, name, *cells])
    return markdown_table(header, table)


def full_resolution_table(rows: list[dict], default: str) -> str:
    """For each setting of ``default``: its PSNR / FLIP and time, and the best of each baseline within that
    time, with the time the baseline needs for the default's PSNR (:func:`speedup`)."""
    baselines = [b for b in BASELINES if any(r["contender"] == b for r in rows)]
    header = ["budget (the default's time)", contender_name(default) if default in CONTENDER_NAMES else default,
              *(f"{contender_name(b)} within it" for b in baselines),
              *(f"{contender_name(b)}: time for the default's PSNR" for b in baselines)]
    table = []
    for setting in (r for r in rows if r["contender"] == default):
        cells = [f"{setting['seconds']:.2f} s", f"{setting['psnr']:.2f} / {setting['flip']:.3f} ({_setting(setting)})"]
        for baseline in baselines:
            best = best_within(rows, baseline, "seconds", setting["seconds"])
            cells.append("cannot run" if best is None else
                         f"{best['psnr']:.2f} / {best['flip']:.3f} ({_setting(best)}, {best['seconds']:.2f} s)")
        cells += [_ratio(speedup(rows, setting, baseline)) for baseline in baselines]
        table.append(cells)
    return markdown_table(header, table)
