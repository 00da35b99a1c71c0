"""``docs/results.md`` and the README's results section, assembled from an evaluation run's record."""
from __future__ import annotations

from ..seeds import BASELINE_SEED_OFFSET
from . import report
from .config import DEFAULT_VARIANT
from .glance import LIMITS_END, LIMITS_START, default_placement, glance_section, glance_table, readme_limits
from .measure import timed_runs
from .plots import GROUPS_PLOT
from .sequences import MOTION_WORDS, motion_of, motions as sequence_motions

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
        f"{c.get('feature_spp', 1)}): full-frame path tracing at the same samples a pixel (between two "
        "whole counts each metric read between theirs, linearly in log samples) and adaptive path tracing with exactly "
        f"rate x {c['spp']} samples a pixel on average (`gmcpt/sampling/adaptive.py`: 5/8 of the samples everywhere, "
        "the rest where the first pass's error in the displayed image is high). `random` is the paper's mask; `adaptive` places the "
        "samples by a density from the feature buffers' edges; `two_pass` spends half the budget "
        "so, then the rest where the first half's samples disagree with their neighbours "
        "(`gmcpt/sampling/placement.py`); `budget` (the default) is `--budget rate x spp`: a 4-spp first pass of `two_pass` "
        "chooses between `two_pass` at rate x 16 spp and tracing every pixel evenly (uniform path tracing at exactly "
        "the budget), dense where the traced means are noisy or the feature buffers busy with edges "
        "(`gmcpt/sampling/budget.py`). PSNR dB / FLIP; the last columns are the default's lead over each baseline."
        + (f" Both baselines and `{default_placement(c)}` are the means of {c['placement_seeds']} seeds ({c['seed']} "
           f"to {c['seed'] + c['placement_seeds'] - 1}; baselines at seed + {BASELINE_SEED_OFFSET}), the other masks one seed: one "
           "seed's PSNR moves by 0.1-0.4 dB a scene." if c.get("placement_seeds", 1) > 1 else ""),
        "",
        placement_table(run),
        "",
    ]


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


def _figure(row: dict, key: str, form: str) -> str:
    """A figure of a record's row, or ``-`` where the record has none (records made before it was measured, a
    still scene's changed pixels)."""
    return format(row[key], form) if row.get(key) is not None else "-"


def _in_place(row: dict, key: str) -> str:
    """`` (x.xx)`` of an in-place figure where the record has one (records before it do not)."""
    return f" ({row[key]:.2f})" if row.get(key) is not None else ""


def sequence_section(sequences: dict | None) -> list[str]:
    """The sequence mode against per-frame path tracing + OIDN and accumulation + OIDN, from the record of
    ``benchmarks/sequence.py --record`` (none: no section): the settings, then per motion its rows and its verdicts
    (speed-up, flicker ratio, the gap on the pixels that changed). Records from before the benchmark ran several
    motions, or measured the changed pixels, read as one motion with ``-`` for what they lack."""
    if not sequences:
        return []
    settings = sequences["settings"]
    lines = ["## Sequences: reusing earlier frames' samples", "",
             f"`{sequences['command']}` on {sequences['date']} (commit {sequences['commit']}, "
             f"{sequences['machine']}): {settings['frames']} frames at {settings['res']}x{settings['res']}, "
             f"references of {settings['reference_spp']} spp; means over the frames after the first "
             f"{settings['warm']}, warm seconds a frame with every stage counted (the baselines' guides one pass of "
             "Mitsuba's `aov` integrator at their samples). *Changed pixels*: the PSNR over the pixels whose true "
             "image changed since the frame before (a moving object's old and new place, its shadow, a light's "
             "patches, what a camera move uncovers: where stale history shows; `changed_pixels` of "
             "`gmcpt/evaluation/stability.py`), pooled over the frames, and their share. Flicker (x100): the RMS "
             "error of frame-to-frame changes of the displayed image against the references' changes, along the "
             "camera's motion (the frame before read where each pixel's surface was) and, in brackets, in place; "
             "both read against two independent references of each frame, so that the references' own noise is no "
             "floor under them. Verdicts: the sequence mode's speed-up at equal quality (geometric mean over its "
             "budgets; above 1x it is faster), its flicker over the baseline's and its changed-pixel PSNR minus the "
             "baseline's at the same seconds a frame (below 0 it is behind where the scene changed).", ""]
    for motion in sequence_motions(sequences):
        rows = [r for r in sequences["rows"] if motion_of(r, settings) == motion]
        verdicts = [v for v in sequences["verdicts"] if motion_of(v, settings) == motion]
        moving = "; ".join(f"{scene}: {what[motion]}" for scene, what in sequences.get("moving", {}).items()
                           if motion in what)
        lines += [f"### {motion}", "", f"{MOTION_WORDS.get(motion, motion)}" + (f" ({moving})." if moving else "."),
                  "", "| scene | contender | samples a pixel a frame | PSNR dB | changed pixels dB (share) | FLIP | "
                  "seconds a frame | flicker (in place) |", "|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r['scene']} | {r['contender']} | {r['spp']:g} | {r['psnr']:.2f} | {_changed(r)} | "
                  f"{_figure(r, 'flip', '.4f')} | {r['seconds']:.3f} | "
                  f"{r['flicker']:.2f}{_in_place(r, 'screen_flicker')} |" for r in rows]
        lines += ["", "| scene | baseline | speed-up | flicker ratio (in place) | changed pixels, dB at equal time |",
                  "|---|---|---|---|---|"]
        lines += [f"| {v['scene']} | {v['baseline']} | {v['speedup']:.2f}x | "
                  f"{_figure(v, 'flicker_ratio', '.2f')}{_in_place(v, 'screen_flicker_ratio')} | "
                  f"{_figure(v, 'changed_gap_db', '+.2f')} |" for v in verdicts]
        lines += ["", *_stage_table(rows)]
    return [*lines, "![sequences: PSNR against seconds a frame, per scene and motion](sequences.png)", ""]


#: A frame's stages as the sequence benchmark records them (``stages`` of a row), in the order a frame runs them
FRAME_STAGES = (("features_s", "survey"), ("placement_s", "history"), ("render_s", "path tracing"),
                ("guides_s", "aov guides"), ("combine_s", "combine"), ("denoise_s", "OIDN"), ("carry_s", "carry"),
                ("other_s", "other"))


def _stage_table(rows: list[dict]) -> list[str]:
    """Where a frame's time goes: milliseconds a frame in each stage of the sequence at its budgets and of per-frame
    path tracing + OIDN at the same samples a pixel; nothing for a record without stages."""
    budgets = {r["spp"] for r in rows if r["contender"] == "sequence"}
    timed = [r for r in rows if r.get("stages") and (r["contender"] == "sequence"
                                                      or (r["contender"] == "path+oidn" and r["spp"] in budgets))]
    if not timed:
        return []
    stages = [(key, label) for key, label in FRAME_STAGES if any(key in r["stages"] for r in timed)]
    lines = ["Where a frame's time goes, milliseconds (warm frames' means):", "",
             "| scene | contender | samples a pixel a frame | " + " | ".join(label for _, label in stages)
             + " | total |",
             "|---|---|---|" + "---|" * (len(stages) + 1)]
    lines += [f"| {r['scene']} | {r['contender']} | {r['spp']:g} | "
              + " | ".join(f"{1000 * r['stages'][key]:.0f}" if key in r["stages"] else "-" for key, _ in stages)
              + f" | {1000 * r['seconds']:.0f} |" for r in timed]
    return [*lines, ""]


def _changed(row: dict) -> str:
    """``24.10 (3.2%)``: a row's PSNR over the changed pixels and their share, ``-`` where it has none."""
    if row.get("psnr_changed") is None:
        return "-"
    return f"{row['psnr_changed']:.2f} ({row['changed_share']:.1%})"


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
        "Mitsuba's own render and its guides a pass of about the budget's samples, 4 to 16 rays a pixel, without "
        "shadow rays; OIDN takes guides of 16 rays or more as noise-free and runs its large model, the baselines' "
        "from 16 spp too). "
        "Timed warm, in one process: each "
        f"contender's whole pipeline runs once to warm up (kernels, weights), the default's twice (its readings of the "
        f"scene, one of which waits on another), then "
        f"{timed_runs(c['repeats'])} times, each run with seeds of its own (both baselines' renders and guides the "
        "default's: a dense frame at an integral budget is the same render as path tracing's, an adaptive one the "
        "same samples as adaptive path tracing's, so they differ by their guides and time, not by one seed's "
        "luck), in rounds of every setting once: the "
        "median run is its time (kernels compiled, weights loaded), the mean over the runs its quality. For each budget, each contender's best setting that fits it: "
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
        "time, taken from one round's runs at a time and the median over the rounds: above 1x the default is faster. `>`: even the baseline's slowest setting falls short; `<`: its "
        "fastest already does better. Means are geometric. *The better of the two* takes, for each setting, the "
        "baseline that needs less time; its *all settings* column is the equal-time verdict of the table at a glance "
        "and of `gmcpt compare` (one function, `report.equal_time_verdict`).",
        "",
        report.speedup_table(budget, DEFAULT_VARIANT),
        "",
        *full_resolution_section(run),
        *sequence_section(run.get("sequences")),
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
        "The default against the better of path tracing + OIDN and adaptive path tracing + OIDN (above 0 dB, above "
        "1x: the default is better):",
        "",
        glance_table(run),
        "",
        f"![Mean PSNR against wall time, real and synthetic scenes](docs/{GROUPS_PLOT})",
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
