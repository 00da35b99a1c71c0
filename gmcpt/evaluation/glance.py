"""The figures a reader needs first, as pure functions of an evaluation's record: the at-a-glance table that opens
``docs/results.md`` and the README's limits (:func:`readme_limits`), both from the verdict functions of
:mod:`~gmcpt.evaluation.report` that the long tables and ``gmcpt compare`` use."""
from __future__ import annotations

import numpy as np

from . import report
from .config import DEFAULT_VARIANT
from .plots import GROUPS_PLOT
from .sequences import glance_line

LIMITS_START = "<!-- limits:start (python -m gmcpt eval) -->"
LIMITS_END = "<!-- limits:end -->"


def default_placement(c: dict) -> str:
    """The placement-table row of the default (runs before the budget chooser had ``mask``)."""
    return c.get("default_placement", c.get("mask", "two_pass"))


def mean_groups(rows: list[dict]) -> list[tuple[str, dict]]:
    """The groups of :func:`report.groups` that are means, not single scenes."""
    return [(label, where) for label, where in report.groups(rows) if "scene" not in where]


def _group_name(label: str) -> str:
    """``**mean of 5 real**`` -> ``5 real``; the mean of every scene -> ``all 9``."""
    name = label.strip("*").removeprefix("mean of ")
    return name if " " in name else f"all {name}"


def _equal_samples(run: dict, where: dict) -> float | None:
    """The default's lead over the better baseline at equal samples, mean over the placement table's rates."""
    c = run["config"]
    leads = [report.equal_samples_lead(run.get("placement", []), default_placement(c), rate, **where)
             for rate in c["rates"]]
    leads = [lead for lead in leads if lead is not None]
    return float(np.mean(leads)) if leads else None


def _budgets(rows: list[dict]) -> str:
    """The default's budgets, as a range: ``1-16``."""
    budgets = sorted({r["rate"] * r["spp"] for r in rows if r["contender"] == DEFAULT_VARIANT})
    return f"{budgets[0]:g}-{budgets[-1]:g}" if len(budgets) > 1 else f"{budgets[0]:g}" if budgets else "-"


def glance_table(run: dict) -> str:
    """Per group mean (real, synthetic, all): the default against the better baseline at equal samples (dB) and at
    equal time (:func:`report.equal_time_verdict`)."""
    c, timed = run["config"], run["equal_time"]
    samples = ", ".join(f"{rate * c['spp']:g}" for rate in c["rates"])
    header = ["scenes", f"equal samples ({samples} spp): default - better baseline, mean dB",
              f"equal time (budgets {_budgets(timed)}): speed-up over the better baseline, geometric mean"]
    table = []
    for label, where in mean_groups(timed or run.get("placement", [])):
        lead = _equal_samples(run, where)
        verdict = report.equal_time_verdict(timed, DEFAULT_VARIANT, scenes=report.in_group(timed, where))
        table.append([_group_name(label), "-" if lead is None else f"{lead:+.2f}",
                      "-" if verdict is None else report.verdict_cell(verdict, False)])
    return report.markdown_table(header, table)


def glance_section(run: dict) -> list[str]:
    """The opening of ``results.md``: the sequence benchmark's verdict in one line where its record is beside the
    run's (:func:`gmcpt.evaluation.sequences.glance_line`), the table, one line on how to read it, the plot per
    group."""
    sequences = [glance_line(run["sequences"]), ""] if run.get("sequences") else []
    return [
        "## At a glance",
        "",
        *sequences,
        f"The default (`{DEFAULT_VARIANT}`) against the better of path tracing + OIDN and adaptive path tracing + "
        "OIDN. Equal samples: PSNR difference, above 0 the default is better. Equal time: the time the better "
        "baseline needs for the default's PSNR over the default's time, above 1x the default is faster "
        "(the last column of *Speed-up at equal quality*; `n bounds`: ratios that are only bounds).",
        "",
        glance_table(run),
        "",
        f"![Mean PSNR against wall time, real and synthetic scenes]({GROUPS_PLOT})",
        "",
        "The long tables follow.",
        "",
    ]


def _scene_verdicts(rows: list[dict]) -> dict[str, float]:
    """scene -> its equal-time verdict (:func:`report.equal_time_verdict`)."""
    verdicts = {s: report.equal_time_verdict(rows, DEFAULT_VARIANT, scenes=[s]) for s in report.row_scenes(rows)}
    return {s: v["speedup"] for s, v in verdicts.items() if v is not None}


def _full_resolution(run: dict) -> str:
    """``; sponza 1920x1080 0.83-0.98x``: the full-resolution check's verdict per budget, as a range."""
    rows = run.get("full_resolution", [])
    settings = list(dict.fromkeys((r["rate"], r["spp"]) for r in rows if r["contender"] == DEFAULT_VARIANT))
    found = [report.equal_time_verdict(rows, DEFAULT_VARIANT, setting=s) for s in settings]
    found = sorted(v["speedup"] for v in found if v is not None)
    if not found:
        return ""
    return f"; {rows[0]['scene']} {rows[0]['size']} " + (f"{found[0]:.2f}-{found[-1]:.2f}x" if len(found) > 1
                                                          else f"{found[0]:.2f}x")


def limits_lines(run: dict) -> list[str]:
    """The README's limits, every figure from the record: equal time, equal samples, the references' noise."""
    timed, c = run["equal_time"], run["config"]
    lines = []
    overall = report.equal_time_verdict(timed, DEFAULT_VARIANT)
    scenes = _scene_verdicts(timed)
    if overall is not None and scenes:
        behind = [s for s, v in scenes.items() if v < 1]
        low = min(scenes.values())
        word = "Faster" if low >= 1 else "Not yet faster" if overall["speedup"] < 1 else "Not on every scene faster"
        lines.append(f"- {word} than path tracing + OIDN at equal time: {overall['speedup']:.2f}x overall, "
                     f"{low:.2f}-{max(scenes.values()):.2f}x a scene against the better\n  "
                     f"baseline (geometric mean, budgets {_budgets(timed)}; below 1x on "
                     f"{', '.join(behind) or 'none'}){_full_resolution(run)}.")
    middle = c["rates"][len(c["rates"]) // 2]
    leads = [(_group_name(label).split()[-1], report.equal_samples_lead(run.get("placement", []),
                                                                          default_placement(c), middle, **where))
             for label, where in mean_groups(run.get("placement", [])) if where]
    leads = [(name, lead) for name, lead in leads if lead is not None]
    if leads:
        signs = {lead < 0 for _, lead in leads}
        if len(signs) == 1:  # all behind or all ahead: one verb, magnitudes
            said = f"{'trails' if signs == {True} else 'leads'} the better baseline by " + ", ".join(
                f"{abs(lead):.2f}{' dB' if index == 0 else ''} ({name})" for index, (name, lead) in enumerate(leads))
        else:
            said = "is " + ", ".join(f"{lead:+.2f}{' dB' if index == 0 else ''} ({name})"
                                     for index, (name, lead) in enumerate(leads)) + " against the better baseline"
        lines.append(f"- At {middle * c['spp']:g} samples it {said}: frames go sparse\n  only where the fill's gain "
                     "outweighs its extra time.")
    if run.get("references"):
        noisiest = min(run["references"], key=lambda r: r["noise_psnr"])
        lines.append(f"- Some references stay noisy at {noisiest['reference_spp']} spp ({noisiest['noise_psnr']:.0f} dB "
                     f"between two on {noisiest['scene']}); no caustics through glass.")
    return lines


def readme_limits(run: dict) -> str:
    """The README's limits between their markers (:func:`gmcpt.evaluation.document.replace_readme_section`)."""
    return "\n".join([LIMITS_START, *limits_lines(run), LIMITS_END])
