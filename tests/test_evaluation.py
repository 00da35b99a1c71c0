"""The evaluation suite: crossover analysis on known rows, a tiny end-to-end run, and CLI errors."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _row(scene, contender, spp_per_pixel, seconds, psnr, rate=1.0, spp=1):
    return {"scene": scene, "contender": contender, "rate": rate, "spp": spp, "samples_per_pixel": spp_per_pixel,
            "seconds": seconds, "psnr": psnr, "ssim": 0.5, "flip": 0.1}


# A completion method that beats the denoiser below 2 spp and loses above; it is also the only one below 1 spp.
ROWS = [
    _row("s", "path+oidn", 1, 1.0, 20.0), _row("s", "path+oidn", 2, 2.0, 26.0), _row("s", "path+oidn", 4, 4.0, 30.0),
    _row("s", "m", 0.5, 0.5, 18.0, 0.5, 1), _row("s", "m", 1, 1.5, 22.0, 0.5, 2), _row("s", "m", 2, 2.5, 25.0, 0.5, 4),
    _row("s", "path", 1, 0.2, 10.0), _row("s", "path", 2, 0.4, 12.0),
]


def test_best_within_picks_the_best_setting_that_fits():
    from gmcpt.evaluation.report import best_within

    assert best_within(ROWS, "m", "samples_per_pixel", 1.0)["psnr"] == 22.0
    assert best_within(ROWS, "m", "samples_per_pixel", 0.4) is None
    assert best_within(ROWS, "path+oidn", "seconds", 3.9)["psnr"] == 26.0


def test_crossover_on_known_rows():
    from gmcpt.evaluation.report import crossover

    samples = crossover(ROWS, "s", "m", "path+oidn", "samples_per_pixel")
    assert samples == ("below 1 spp only m can run, m is ahead of path tracing + OIDN up to 1 spp and behind "
                       "from 2 spp")
    time = crossover(ROWS, "s", "m", "path+oidn", "seconds")
    # 1 s: m 18 vs oidn 20 -> behind; 1.5 s: 22 vs 20 -> ahead; 2 s: 22 vs 26, 2.5 s: 25 vs 26 -> behind
    assert time == ("below 1.00 s only m can run, m is ahead of path tracing + OIDN at 1 of 5 budgets (1.50 s)")


def test_budget_table_mean_and_no_repeated_rows():
    from gmcpt.evaluation.report import budget_table

    rows = ROWS + [dict(r, scene="t", psnr=r["psnr"] + 2) for r in ROWS]
    table = budget_table(rows, "samples_per_pixel")
    mean_rows = [line for line in table.splitlines() if line.startswith("| **mean of 2**")]
    # budgets 0.125 and 0.25: nothing fits; 0.5: only m; 1, 2, 4: all change; 8..64 repeat 4 and are left out
    assert [line.split(" | ")[1] for line in mean_rows] == ["0.5", "1", "2", "4"]
    cells = mean_rows[1].split(" | ")  # columns in order of appearance: path+oidn, m, path
    assert cells[2].startswith("21.00 / 0.500") and cells[3].startswith("23.00 / 0.500")  # (20 + 22) / 2, (22 + 24) / 2


def test_readme_section_is_replaced_between_markers():
    from gmcpt.evaluation.document import README_END, README_START, replace_readme_section

    readme = f"# T\n\nintro\n\n{README_START}\nold\n{README_END}\n\n## Next\n"
    out = replace_readme_section(readme, f"{README_START}\nnew\n{README_END}")
    assert "new" in out and "old" not in out and out.startswith("# T\n\nintro") and out.endswith("## Next\n")
    assert replace_readme_section("# T\n", "S").endswith("## Results\n\nS\n")


def test_tiny_evaluation_end_to_end(mi, tmp_path, monkeypatch):
    """Every table, plot and README section from a small run on the Cornell box and one procedural scene."""
    from gmcpt.evaluation.scenes import CORNELL, ProceduralScene
    from gmcpt.evaluation.cli import evaluate
    from gmcpt.evaluation.config import EvalConfig
    from gmcpt.evaluation.document import readme_section, results_markdown

    monkeypatch.setenv("GMCPT_CACHE", str(tmp_path / "cache"))
    config = EvalConfig(name="test", procedural=1, resolution=32, reference_spp=32, rates=(0.3, 0.5),
                        variants=("interp", "nnm", "pawnnm"), patch_sizes=(5, 7), path_spp=(1, 2),
                        budget_rates=(0.5,), budget_spp=(1, 2), budget_variants=("interp",),
                        timing_resolutions=(32,), timing_scene="cornell-box", repeats=1)
    out = tmp_path / "docs"
    out.mkdir()
    record = evaluate(config, [CORNELL, ProceduralScene(2_000_003)], out, lambda message: None)
    record.update(command="test", date="today", commit="abc", versions={"gmcpt": "0"}, machine="here")
    assert {r["scene"] for r in record["quality"]} == {"cornell-box", "proc-2000003"}
    assert len(record["quality"]) == 2 * (2 * 3 + 2)  # scenes x (rates x variants + patch sizes at rate 0.3)
    assert {r["contender"] for r in record["equal_time"]} == {"path", "path+oidn", "interp"}
    noise = record["references"][0]
    assert np.isfinite(noise["noise_psnr"]) and noise["noise_psnr"] > 10
    # a completion at a higher rate is better: the measurements are real
    pawnnm = {r["rate"]: r["psnr"] for r in record["quality"] if r["variant"] == "pawnnm" and r["scene"] == "cornell-box"}
    assert pawnnm[0.5] > pawnnm[0.3]
    placements = {r["variant"] for r in record["placement"]}
    assert placements == {"path+oidn", "random", "stratified", "adaptive", "two_pass"}
    for row in record["placement"]:  # equal samples: the masks spend round(rate * pixels) x spp, path tracing
        expected = round(row["rate"] * 32 * 32) * 16 / (32 * 32) if row["variant"] != "path+oidn" \
            else round(row["rate"] * 16)
        assert row["samples_per_pixel"] == pytest.approx(expected)
    markdown = results_markdown(record)
    assert "Sample placement at equal samples" in markdown and "two_pass - path+oidn dB" in markdown
    assert "with each sample placement against path tracing + OIDN" in readme_section(record)
    for heading in ("Table 1", "Table 2", "Fig. 10", "Fig. 12", "Table 3", "Crossover", "Table 4"):
        assert heading in markdown
    assert "pawnnm - nnm" in markdown
    for png in ("psnr_vs_time.png", "psnr_vs_rate.png", "grid-cornell-box.png", "grid-proc-2000003.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "docs/psnr_vs_time.png" in readme_section(record)
    json.dumps(record, default=float)  # the record is what results.json holds


def _eval(*args):
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    return subprocess.run([sys.executable, "-m", "gmcpt", "eval", *args], capture_output=True, text=True, cwd=ROOT,
                          env=env, timeout=300)


@pytest.mark.parametrize("args, message", [
    (["--scenes", "kitchen"], "unknown scene kitchen"),
    (["--procedural", "-1"], "--procedural must be >= 0"),
    (["--out", "README.md", "--no-readme"], "--out README.md is not a folder"),
    (["--bogus"], "unrecognized arguments"),
])
def test_eval_bad_input_is_one_line(args, message):
    result = _eval(*args)
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
