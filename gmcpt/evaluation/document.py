"""``docs/results.md`` and the README's results section, assembled from an evaluation run's record."""
from __future__ import annotations

from . import report
from .glance import LIMITS_END, LIMITS_START, default_placement, glance_section, mean_groups, readme_limits
from .config import DEFAULT_VARIANT

README_START = "<!-- results:start (written by python -m gmcpt eval; do not edit) -->"
README_END = "<!-- results:end -->"


def _settings_line(run: dict) -> str:
    c = run["config"]
    return (f"{c['resolution']}x{c['resolution']}, {c['spp']} spp per traced pixel, {c.get('feature_spp', 1)}-spp feature pass, "
            f"the default as `--budget rate x {c['spp']}`, seed {c['seed']}, "
            f"references {c['reference_spp']} spp; metrics on tonemapped sRGB (clamp to [0, 1], sRGB curve) "
            "except relMSE (linear); FLIP is `flip-evaluator`'s LDR mean (0 = identical).")


def placement_table(run: dict) -> str:
    """PSNR / FLIP of each placement beside both baselines at equal samples, per scene and the means."""
    c = run["config"]
    default = default_placement(c)
    return report.variant_table(run.get("placement", []), [*report.BASELINES, *c.get("placements", ())],
                                ["psnr", "flip"], c["rates"], deltas=[(default, baseline) for baseline in report.BASELINES])


def placement_section(run: dict) -> list[str]:
    c = run["config"]
    if not run.get("placement"):
        return []
    return [
        "## Sample placement at equal samples",
        "",
        f"`{c['placement_variant']}` at each rate x {c['spp']} spp with each mask, beside two baselines denoised by "
        "Intel Open Image Denoise (albedo and normal from a feature pass of as many primary samples a pixel as "
        "their own path samples, what a renderer accumulates in the same pass; the default's feature pass has "
        f"{c.get('feature_spp', 1)}): full-frame path tracing with the "
        f"same total samples (round(rate x {c['spp']}) spp a pixel) and adaptive path tracing with exactly "
        f"rate x {c['spp']} samples a pixel on average (`gmcpt/adaptive.py`: 5/8 of the samples everywhere, "
        "the rest where the first pass's error in the displayed image is high). `random` is the paper's mask; `adaptive` places the "
        "samples by a density from the feature buffers' edges; `two_pass` spends half the budget "
        "so, then the rest where the first half's samples disagree with their neighbours "
        "(`gmcpt/placement.py`); `budget` (the default) is `--budget rate x spp`: a 4-spp first pass of `two_pass` "
        "chooses between `two_pass` at rate x 16 spp and tracing every pixel evenly (uniform path tracing at exactly "
        "the budget), dense where the traced means are noisy or the feature buffers busy with edges "
        "(`gmcpt/budget.py`). PSNR dB / FLIP; the last columns are the default's lead over each baseline."
        + (f" Both baselines and `{default_placement(c)}` are the means of {c['placement_seeds']} seeds ({c['seed']} "
           f"to {c['seed'] + c['placement_seeds'] - 1}; baselines at seed + 17), the other masks one seed: one "
           "seed's PSNR moves by 0.1-0.4 dB a scene." if c.get("placement_seeds", 1) > 1 else ""),
        "",
        placement_table(run),
        "",
    ]


def readme_placement(run: dict) -> list[str]:
    """Equal samples in the README: both baselines and the default, mean PSNR of the real and synthetic scenes."""
    rows = run.get("placement", [])
    if not rows:
        return []
    c = run["config"]
    default = default_placement(c)
    columns = [v for v in [*report.BASELINES, default] if any(r["variant"] == v for r in rows)]
    table = []
    for label, where in mean_groups(rows):
        for rate in c["rates"]:
            lead = report.equal_samples_lead(rows, default, rate, **where)
            table.append([label.strip("*"), f"{rate:g} x {c['spp']} = {rate * c['spp']:g}",
                          *(f"{report._mean(rows, 'psnr', variant=v, rate=rate, **where):.2f}" for v in columns),
                          "-" if lead is None else f"{lead:+.2f}"])
    names = [report.contender_name(v) if v in report.CONTENDER_NAMES else f"default ({c['placement_variant']})"
             for v in columns]
    return ["Mean PSNR (dB) at equal samples per pixel:", "",
            report._table(["scenes", "samples / pixel", *names, "default - better baseline"], table), ""]


def verdict(run: dict) -> list[str]:
    """Plain sentences: where the default wins and where it loses, at equal samples and at equal time."""
    rows, c = run.get("placement", []), run["config"]
    if not rows:
        return []
    default = default_placement(c)
    middle = c["rates"][len(c["rates"]) // 2]
    behind = [(s, report.equal_samples_lead(rows, default, middle, scene=s)) for s in report._scenes(rows)]
    behind = [f"{s} ({lead:+.2f} dB)" for s, lead in behind if lead is not None and lead < -0.005]
    lines = [f"At {middle * c['spp']:g} samples per pixel the default is behind the better baseline on "
             + (", ".join(behind) if behind else "no scene") + "."]
    timed = run.get("equal_time", [])
    counts = []
    for _, where in mean_groups(timed):
        ahead = total = 0
        for scene in report._in_group(timed, where):
            scene_rows = [r for r in timed if r["scene"] == scene]
            for setting in (r for r in scene_rows if r["contender"] == c.get("placement_variant", "gan_oidn")):
                rivals = [report.best_within(scene_rows, b, "seconds", setting["seconds"]) for b in report.BASELINES]
                rivals = [r["psnr"] for r in rivals if r is not None]
                total += 1
                ahead += not rivals or setting["psnr"] > max(rivals)
        kind = {True: "real", False: "synthetic"}.get(where.get("real"), "all")
        counts.append(f"{ahead} of its {total} settings on {kind} scenes")
    if counts:
        lines.append("At equal time (warm, every stage counted) it is ahead of both baselines at "
                     + (", ".join(counts[:-1]) + " and " if len(counts) > 1 else "") + counts[-1] + ".")
    return [" ".join(lines), ""]


def full_resolution_section(run: dict) -> list[str]:
    rows = run.get("full_resolution", [])
    if not rows:
        return []
    c = run["config"]
    return [
        f"## Full resolution: {rows[0]['scene']} at {rows[0]['size']}",
        "",
        f"The default at budgets of {', '.join(f'{b:g}' for b in c['full_budgets'])} samples a pixel; its warm time is the "
        f"budget. Within it, the best of path tracing + OIDN at {', '.join(map(str, c['full_path_spp']))} spp and "
        f"of adaptive path tracing + OIDN at {', '.join(f'{b:g}' for b in c['full_adaptive_budgets'])} samples a "
        f"pixel (timed as in Table 3), against a {c['full_reference_spp']}-spp reference. PSNR dB / FLIP.",
        "",
        report.full_resolution_table(rows, DEFAULT_VARIANT),
        "",
    ]


def results_markdown(run: dict) -> str:
    c, quality, budget = run["config"], run["quality"], run["equal_time"]
    rates = c["rates"]
    scenes = ", ".join(f"`{name}`" for name in dict.fromkeys(r["scene"] for r in quality))
    parts = [
        "# Results",
        "",
        *glance_section(run),
        f"Regenerated by `{run['command']}` ({c['name']} mode) on {run['date']}; do not edit by hand. "
        f"Machine: {run['machine']}. Commit {run['commit']}. Wall time of the run: {run['seconds'] / 60:.1f} min.",
        "",
        f"Scenes: {scenes}. Held-out procedural scenes are seeds of the dataset's test split, never trained on; "
        "`breakfast-room-open` is `../shared/scenes/breakfast-room` with its window panes left out "
        "(see `gmcpt/evaluation/scenes.py` for why). The real scenes (their own means in every table) are "
        "imported from public Mitsuba 0.6 ports by `scripts/import_scenes.py`:",
        "",
        *[f"- `{name}`: {credit}" for name, credit in run.get("credits", {}).items()],
        "",
        f"Settings: {_settings_line(run)}",
        "",
        "Methods:",
        report.variant_legend(list(c["variants"])),
        "",
        "Library versions: " + ", ".join(f"{k} {v}" for k, v in run["versions"].items()) + ".",
        "",
        "## References and their noise",
        "",
        "Each reference against an independent second one (seed "
        f"{run['second_reference_seed']}): the floor below which a method's error cannot be measured.",
        "",
        report.reference_table(run["references"]),
        "",
        *placement_section(run),
        "## Table 1: the full method against the Liu-style baseline (paper Table 1)",
        "",
        "SSIM and MSE (tonemapped sRGB) at 20/30/40 % sampling. `liu` is classical pre-completion + NNM on image "
        "features only; `pawnnm` the classical method; `gan_pawnnm` the paper's full method.",
        "",
        report.variant_table(quality, ["liu", "pawnnm", "gan_pawnnm"], ["ssim", "mse"], rates),
        "",
        "## Table 2: NNM against PAWNNM (paper Table 2)",
        "",
        report.variant_table(quality, ["nnm", "pawnnm"], ["psnr", "ssim", "mse"], rates, deltas=[("pawnnm", "nnm")]),
        "",
        "## With and without GAN pre-completion (paper Fig. 10)",
        "",
        report.variant_table(quality, ["interp", "gan", "pawnnm", "gan_pawnnm"], ["psnr", "ssim"], rates,
                             deltas=[("gan_pawnnm", "pawnnm")]),
        "",
        "## Beyond the paper: the fill, the traced samples, then OIDN",
        "",
        "`gan_oidn` (the default) and `gan_pawnnm_oidn` put each traced pixel's samples back over the fill of "
        "`gan` or `gan_pawnnm` and run Intel Open Image Denoise (albedo and normal of the feature pass) over the "
        "frame (`gmcpt/completion/denoised.py`). PSNR dB / FLIP; the last column is the default's gain over "
        "the paper's method.",
        "",
        report.variant_table(quality, ["gan", "gan_pawnnm", "gan_oidn", "gan_pawnnm_oidn"], ["psnr", "flip"], rates,
                             deltas=[("gan_oidn", "gan_pawnnm")]),
        "",
        "## PSNR against patch size (paper Fig. 12)",
        "",
        "PAWNNM with n x n patches stepped by n - 2 (7x7 is the default); PSNR dB.",
        "",
        report.patch_table(quality, c["patch_sizes"], c["patch_rates"]),
        "",
        "## Table 3: equal time and equal samples against path tracing and OIDN",
        "",
        "Every contender ran at several settings in this run: full-frame path tracing at "
        f"{', '.join(map(str, c['path_spp']))} spp; the same + Intel Open Image Denoise (`pyoidn`, CPU, HDR, "
        "with albedo and normal from the project's feature pass at its own samples a pixel, which OIDN prefers to "
        "Mitsuba's albedo on scenes with metals, charged the time of Mitsuba's `aov` pass (albedo, normal) at as "
        "many samples); adaptive path tracing + OIDN at "
        f"{', '.join(f'{b:g}' for b in c.get('adaptive_budgets', ()))} samples a pixel on average; the completion "
        f"methods at rates {', '.join(f'{r:g}' for r in c['budget_rates'])} x {', '.join(map(str, c['budget_spp']))} spp "
        "(guides or feature pass, probe, placement, render and completion counted; the default's dense frames are "
        "Mitsuba's own render and its guides a pass of about the budget's samples without shadow rays). Timed warm, in one process: each "
        f"contender's whole pipeline runs {max(2, c['repeats'])} times, each run with seeds of its own: the "
        "fastest run is its time (kernels compiled, weights loaded), the mean over the runs its quality. For each budget, each contender's best setting that fits it: "
        "PSNR dB / SSIM / FLIP. Path tracing cannot spend less than 1 sample per pixel.",
        "",
        "### Crossover",
        "",
        "`completion` is the best of " + ", ".join(f"`{v}`" for v in c["budget_variants"]) + " at each budget.",
        "",
        report.crossover_table(budget),
        "",
        "Per method:",
        "",
        *report.crossover_lines(budget),
        "",
        "### Equal samples (path samples per pixel: rate x spp for the completion methods)",
        "",
        report.budget_table(budget, "samples_per_pixel"),
        "",
        "### Equal time (budget in units of the scene's 1-spp full-frame render time on this machine)",
        "",
        report.budget_table(budget, "seconds"),
        "",
        "### Speed-up at equal quality",
        "",
        f"For each setting of the default (`{DEFAULT_VARIANT}`), the time each baseline needs to reach its PSNR "
        "(interpolated in log time on the baseline's best-PSNR-within-time curve), as a multiple of the default's "
        "time: above 1x the default is faster. `>`: even the baseline's slowest setting falls short; `<`: its "
        "fastest already does better. Means are geometric. *The better of the two* takes, for each setting, the "
        "baseline that needs less time; its *all settings* column is the equal-time verdict of the table at a glance "
        "and of `gmcpt compare` (one function, `report.equal_time_verdict`).",
        "",
        report.speedup_table(budget, DEFAULT_VARIANT),
        "",
        *full_resolution_section(run),
        "## Table 4: stage timings per resolution",
        "",
        f"Scene `{c['timing_scene']}`, rate 0.3, {c['spp']} spp, wall seconds on this machine "
        "(pre-completion is the classical fill for `pawnnm`, GAN inference for the others).",
        "",
        report.stage_table(run["stage_timings"]),
        "",
        "## Plots",
        "",
        "![PSNR against time](psnr_vs_time.png)",
        "",
        "![PSNR against rate](psnr_vs_rate.png)",
        "",
        *[f"![{name}]({file})\n" for name, file in run["grids"].items()],
        "All rows, with MSE, relMSE and timings: [`results.json`](results.json).",
        "",
    ]
    return "\n".join(parts)


def readme_section(run: dict) -> str:
    return "\n".join([
        README_START,
        "",
        f"{len(run.get('real_scenes', []))} real and "
        f"{len({r['scene'] for r in run['quality']}) - len(run.get('real_scenes', []))} synthetic scenes "
        f"({_settings_line(run)}), from `{run['command']}` on {run['date']}.",
        "",
        *readme_placement(run),
        *verdict(run),
        "![PSNR against wall time: path tracing, path tracing + OIDN, and the completion methods](docs/psnr_vs_time.png)",
        "",
        "Every table (the paper's, equal time, timings) and plot: [docs/results.md](docs/results.md).",
        "",
        README_END,
    ])


def replace_readme_section(readme: str, section: str, start: str = README_START, end: str = README_END,
                           heading: str = "## Results") -> str:
    """``readme`` with the text from ``start`` to ``end`` replaced by ``section`` (which holds both markers);
    appended under ``heading`` if the markers are missing."""
    if start in readme and end in readme:
        head = readme[:readme.index(start)]
        tail = readme[readme.index(end) + len(end):]
        return head + section + tail
    return readme.rstrip("\n") + f"\n\n{heading}\n\n" + section + "\n"


def rewrite_readme(readme: str, run: dict) -> str:
    """``readme`` with its results section and its limits regenerated from ``run``."""
    readme = replace_readme_section(readme, readme_section(run))
    return replace_readme_section(readme, readme_limits(run), LIMITS_START, LIMITS_END, "## Limits")
