"""What ``gmcpt compare`` measures and says, as pure functions: its configuration (the evaluation's
:class:`~gmcpt.evaluation.config.EvalConfig` restricted to the user's budgets), the per-budget figures at equal
samples and at equal time, the table and the verdict (:func:`gmcpt.evaluation.report.equal_time_verdict`, the
function behind the evaluation's speed-up table), with the run's noise (:func:`verdict_noise`) and the budget
chooser's way at each budget (:func:`choices`)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import report
from .config import DEFAULT_VARIANT, QUICK, EvalConfig
from .sequences import NOISE_DRAWS, NOISE_LEVEL, within_noise

#: the default budgets: a 128x128 scene takes a minute or two once its reference exists
DEFAULT_BUDGETS = (2.0, 4.0, 8.0)
#: the largest budget: the baselines run at up to twice it, and adaptive path tracing takes at most 64 spp
MAX_BUDGET = 32.0
#: the baselines are path tracers: they cannot spend less than one sample a pixel
MIN_BUDGET = 1.0
#: samples per pixel of a reference ``gmcpt compare`` renders itself (cached, passes of 256)
REFERENCE_SPP = 1024


def path_ladder(budgets) -> tuple[int, ...]:
    """Path tracing's sample counts: powers of two up to twice the largest budget (its time curve reaches past
    the default's, so that the time it needs for the default's PSNR is interpolated, not bounded), and each budget
    rounded (equal samples)."""
    top = 2 * max(budgets)
    powers = {2 ** k for k in range(int(np.log2(top)) + 1)}
    return tuple(sorted(powers | {max(1, round(b)) for b in budgets}))


def compare_config(budgets, seed: int) -> EvalConfig:
    """The evaluation's configuration with the default at ``budgets`` alone, both baselines at every budget and
    at twice the largest (:func:`path_ladder`), the evaluation's repeats and seeds from ``seed``."""
    budgets = tuple(sorted(set(float(b) for b in budgets)))
    return replace(QUICK, name="compare", seed=seed, default_budgets=budgets, path_spp=path_ladder(budgets),
                   adaptive_budgets=tuple(sorted(set(budgets) | {2 * max(budgets)})),
                   budget_variants=(DEFAULT_VARIANT,))


def setting_weight(samples: float) -> float:
    """Relative cost of one setting of the comparison, for the time left: its samples, plus one for the
    overheads (guides, denoiser, the GAN) that do not shrink with them."""
    return float(samples) + 1.0


def nearest_in_time(rows: list[dict], contender: str, seconds: float) -> dict | None:
    """The contender's row whose time is nearest ``seconds`` (in ratio)."""
    chosen = [r for r in rows if r["contender"] == contender]
    return min(chosen, key=lambda r: abs(np.log(r["seconds"] / seconds))) if chosen else None


def _figures(row: dict | None) -> dict | None:
    if row is None:
        return None
    keep = ("psnr", "ssim", "flip", "mse", "relmse", "seconds", "samples_per_pixel", "spp", "budget_choice")
    return {key: row[key] for key in keep if key in row}


def per_budget(rows: list[dict]) -> list[dict]:
    """For each setting of the default: its figures; each baseline's best at the same samples and within the same
    time (:func:`report.best_within`); the time each baseline, and the better, needs for its PSNR over its time
    (:func:`report.speedup`, :func:`report.better_speedup`)."""
    out = []
    baselines = [b for b in report.BASELINES if any(r["contender"] == b for r in rows)]
    for row in (r for r in rows if r["contender"] == DEFAULT_VARIANT):
        budget = row["rate"] * row["spp"]
        speedups = {b: report.speedup(rows, row, b) for b in baselines}
        out.append({
            "budget": budget, "default": _figures(row),
            "equal_samples": {b: _figures(report.best_within(rows, b, "samples_per_pixel", budget)) for b in baselines},
            "equal_time": {b: _figures(report.best_within(rows, b, "seconds", row["seconds"])) for b in baselines},
            "speedup": {b: None if s is None else {"bound": s[0], "ratio": s[1]} for b, s in speedups.items()},
            "better_speedup": _bound(report.better_speedup(rows, row, baselines)),
        })
    return out


def _bound(value: tuple[str, float] | None) -> dict | None:
    return None if value is None else {"bound": value[0], "ratio": value[1]}


def choices(rows: list[dict]) -> dict[str, str]:
    """The budget chooser's way (``sparse`` or ``dense``) at each budget of the default, keyed by the budget
    (``"4"``); budgets whose rows do not record it are left out."""
    return {f"{r['rate'] * r['spp']:g}": r["budget_choice"] for r in rows
            if r["contender"] == DEFAULT_VARIANT and "budget_choice" in r}


def _in_drawn_rounds(row: dict, rounds) -> dict:
    """``row`` with its times in the timing rounds ``rounds`` alone, in their order (None where it did not run:
    :func:`report.speedup` then counts its median, as it does for a round a setting missed)."""
    times = row.get("round_seconds") or []
    return dict(row, round_seconds=[times[i] if i < len(times) else None for i in rounds])


def verdict_noise(rows: list[dict], draws: int = NOISE_DRAWS, level: float = NOISE_LEVEL, seed: int = 0) -> dict:
    """How far the run's noise moves :func:`verdict`'s speed-up: a paired bootstrap, as
    :func:`gmcpt.evaluation.sequences.verdict_noise` does over an animation's frames. Each draw takes as many of the
    default's budgets as it ran, with replacement, and for each, as many of its timing rounds as it ran
    (``round_seconds``), with replacement, the same rounds for every baseline (each speed-up pairs runs of one
    round: :func:`report.speedup`); the draw's speed-up is the geometric mean of the better baseline's ratios
    (:func:`report.better_speedup`), as :func:`report.equal_time_verdict` reads it. So a budget where the default
    loses and one where it wins, or rounds whose ratios straddle 1, widen the interval; the interval holds
    ``level`` of the draws. Rows without round times are resampled by budget alone.

    Returns ``{"speedup": (low, high) or None, "over", "draws", "level"}`` (``over``: what was resampled)."""
    mine = [r for r in rows if r["contender"] == DEFAULT_VARIANT]
    others = [r for r in rows if r["contender"] in report.BASELINES]
    random = np.random.default_rng(seed)
    found = []
    for _ in range(draws if mine else 0):
        ratios = []
        for index in random.integers(0, len(mine), len(mine)):
            row = mine[index]
            ran = [i for i, seconds in enumerate(row.get("round_seconds") or []) if seconds is not None]
            drawn = [row, *others]
            if ran:
                rounds = random.choice(ran, len(ran))
                drawn = [_in_drawn_rounds(r, rounds) for r in drawn]
            ratio = report.better_speedup(drawn, drawn[0])
            if ratio is not None:
                ratios.append(np.log(ratio[1]))
        if ratios:
            found.append(float(np.exp(np.mean(ratios))))
    tail = 100 * (1 - level) / 2
    spread = tuple(float(v) for v in np.percentile(found, [tail, 100 - tail])) if found else None
    return {"speedup": spread, "over": "budgets and timing rounds", "draws": draws, "level": level}


def verdict(rows: list[dict], seed: int = 0) -> tuple[dict | None, dict, str]:
    """The equal-time verdict (:func:`report.equal_time_verdict`: the evaluation's own), its noise
    (:func:`verdict_noise`) and its line: "a wash (within the run's noise: ...)" where the interval holds 1, and
    first, where the default went dense at every budget, that it traced every pixel (path tracing + OIDN with its
    own guides, not the sparse way)."""
    found = report.equal_time_verdict(rows, DEFAULT_VARIANT)
    noise = verdict_noise(rows, seed=seed) if found else {}
    budgets = ", ".join(f"{r['rate'] * r['spp']:g}" for r in rows if r["contender"] == DEFAULT_VARIANT)
    spread = noise.get("speedup")
    if found is None:
        said = report.verdict_sentence(found, DEFAULT_VARIANT, f"budgets {budgets}")
    elif within_noise(spread):
        count, total = found["bounds"], found["settings"]
        bounds = f"; {count} of {total} ratio{'s' if total > 1 else ''} only {'bounds' if count > 1 else 'a bound'}" \
            if count else ""
        said = (f"{DEFAULT_VARIANT} against the better baseline at equal quality: a wash (within the run's noise: a "
                f"speed-up of {found['speedup']:.2f}x, {spread[0]:.2f}-{spread[1]:.2f}x; geometric mean over budgets "
                f"{budgets}{bounds})")
    else:
        shown = spread if found["speedup"] >= 1 else spread and (1 / spread[1], 1 / spread[0])
        said = report.verdict_sentence(found, DEFAULT_VARIANT, f"budgets {budgets}")  # it ends with ")"
        if shown:
            said = said[:-1] + f"; {shown[0]:.2f}-{shown[1]:.2f}x within the run's noise)"
    ways = choices(rows)
    if ways and set(ways.values()) == {"dense"}:
        said = (f"{DEFAULT_VARIANT} traced every pixel at every budget (dense): it is path tracing + OIDN with its "
                f"own guides here; " + said)
    return found, noise, "verdict: " + said


def _psnr(figures: dict | None, with_setting: bool = False) -> str:
    if figures is None:
        return "-"
    setting = f" ({figures['spp']:g} spp, {figures['seconds']:.2f} s)" if with_setting else ""
    return f"{figures['psnr']:.2f}{setting}"


def _speedup(value: dict | None) -> str:
    return "-" if value is None else {"=": "", "<": "<", ">": ">"}[value["bound"]] + f"{value['ratio']:.2f}x"


def table(budgets: list[dict]) -> str:
    """The per-budget table: PSNR dB at equal samples, at equal time, and the speed-up over the better baseline."""
    names = {"path+oidn": "path+OIDN", "adaptive+oidn": "adaptive+OIDN"}
    baselines = [b for b in report.BASELINES if budgets and b in budgets[0]["equal_samples"]]
    header = ["budget (spp)", f"{DEFAULT_VARIANT} PSNR (time, frame)",
              *(f"{names[b]} same spp" for b in baselines), *(f"{names[b]} within {DEFAULT_VARIANT}'s time" for b in baselines),
              "speed-up over the better"]
    lines = []
    for entry in budgets:
        mine = entry["default"]
        lines.append([f"{entry['budget']:g}",
                      f"{mine['psnr']:.2f} ({mine['seconds']:.2f} s, {mine.get('budget_choice', '-')})",
                      *(_psnr(entry["equal_samples"][b]) for b in baselines),
                      *(_psnr(entry["equal_time"][b], True) for b in baselines), _speedup(entry["better_speedup"])])
    return report.markdown_table(header, lines)


def equal_samples_line(budgets: list[dict]) -> str:
    """One line: the default against path tracing + OIDN at the same samples, mean PSNR difference."""
    leads = [entry["default"]["psnr"] - entry["equal_samples"]["path+oidn"]["psnr"] for entry in budgets
             if entry["equal_samples"].get("path+oidn")]
    if not leads:
        return "equal samples: path tracing + OIDN did not run at the budgets"
    return (f"equal samples: {DEFAULT_VARIANT} is {np.mean(leads):+.2f} dB against path tracing + OIDN at the same "
            f"samples a pixel (mean over {len(leads)} budget{'s' if len(leads) > 1 else ''})")
