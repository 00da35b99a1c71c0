"""The evaluation suite: crossover analysis on known rows, a tiny end-to-end run, and CLI errors."""
import dataclasses
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
    """Every table, plot and README section from a small run on the Cornell box (standing in for a real scene)
    and one procedural scene."""
    from dataclasses import replace

    from gmcpt.evaluation import measure
    from gmcpt.evaluation.scenes import CORNELL, ProceduralScene
    from gmcpt.cli.eval import evaluate
    from gmcpt.evaluation.config import EvalConfig
    from gmcpt.evaluation.document import readme_section, results_markdown

    from gmcpt.gan import runtime

    from gmcpt.sampling import costs

    generators = runtime.cache_dir()  # the generator's conversion stays the user's: a conversion is 10 s, not tested here
    stored = costs.machine_costs_path()  # and so does the machine's cost model: a measurement is 5-15 s
    monkeypatch.setenv("GMCPT_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(runtime, "cache_dir", lambda: generators)
    monkeypatch.setattr(costs, "machine_costs_path", lambda: stored)
    monkeypatch.setattr(measure, "FULL_REFERENCES", tmp_path / "full")
    config = EvalConfig(name="test", procedural=1, resolution=32, reference_spp=32, rates=(0.3, 0.5),
                        variants=("interp", "nnm", "pawnnm"), patch_sizes=(5, 7), path_spp=(1, 2),
                        adaptive_budgets=(1.5, 3), budget_rates=(0.5,), budget_spp=(1, 2),
                        budget_variants=("interp", "gan_oidn"), timing_resolutions=(32,), timing_scene="cornell-box",
                        repeats=1, full_scene="cornell-box", full_size=(48, 32), full_reference_spp=16,
                        full_budgets=(1, 2), full_path_spp=(1, 2), full_adaptive_budgets=(1.5, 2),
                        default_budgets=(1, 4), placement_seeds=2)
    out = tmp_path / "docs"
    out.mkdir()
    record = evaluate(config, [replace(CORNELL, real=True), ProceduralScene(2_000_003)], out, lambda message: None)
    record.update(command="test", date="today", commit="abc", versions={"gmcpt": "0"}, machine="here")
    assert {r["scene"] for r in record["quality"]} == {"cornell-box", "proc-2000003"}
    assert record["real_scenes"] == ["cornell-box"]
    assert {r["real"] for r in record["quality"] if r["scene"] == "cornell-box"} == {True}
    assert len(record["quality"]) == 2 * (2 * 3 + 2)  # scenes x (rates x variants + patch sizes at rate 0.3)
    assert {r["contender"] for r in record["equal_time"]} == {"path", "path+oidn", "adaptive+oidn", "interp",
                                                              "gan_oidn"}
    full = record["full_resolution"]
    assert {r["size"] for r in full} == {"48x32"} and {r["contender"] for r in full} == {
        "path", "path+oidn", "adaptive+oidn", "gan_oidn"}
    assert (tmp_path / "full").is_dir()
    noise = record["references"][0]
    assert np.isfinite(noise["noise_psnr"]) and noise["noise_psnr"] > 10
    # a completion at a higher rate is better: the measurements are real
    pawnnm = {r["rate"]: r["psnr"] for r in record["quality"] if r["variant"] == "pawnnm" and r["scene"] == "cornell-box"}
    assert pawnnm[0.5] > pawnnm[0.3]
    placements = {r["variant"] for r in record["placement"]}
    assert placements == {"path+oidn", "adaptive+oidn", "random", "stratified", "adaptive", "two_pass", "budget"}
    for row in record["placement"]:  # equal samples: the masks spend round(rate * pixels) x spp, path tracing
        # rate * spp a pixel, adaptive path tracing round(rate * spp * pixels) in all, the budget at most that
        expected = {"path+oidn": row["rate"] * 16, "adaptive+oidn": round(row["rate"] * 16 * 32 * 32) / 1024}
        if row["variant"] == "budget":
            assert row["rate"] * 16 - 16 / 1024 <= row["samples_per_pixel"] <= round(row["rate"] * 16 * 1024) / 1024
        else:
            assert row["samples_per_pixel"] == pytest.approx(expected.get(row["variant"],
                                                                          round(row["rate"] * 32 * 32) * 16 / 1024))
    chosen = [r for r in record["equal_time"] if r["contender"] == "gan_oidn"]
    assert len(chosen) == 2 * 2 and {r["budget_choice"] for r in chosen} <= {"sparse", "dense"}
    averaged = {r["variant"]: r["seeds"] for r in record["placement"] if r["variant"] in ("path+oidn", "budget")}
    assert averaged == {"path+oidn": 2, "budget": 2}  # the baselines and the default: means of the 2 seeds
    assert {r["seeds"] for r in record["placement"] if r["variant"] == "random"} == {1}
    markdown = results_markdown(record)
    assert "Sample placement at equal samples" in markdown and "budget - path+oidn dB" in markdown
    assert "the means of 2 seeds" in markdown
    assert "budget - adaptive+oidn dB" in markdown and "budget 4" in markdown
    assert "**mean of 1 real**" in markdown and "**mean of 1 synthetic**" in markdown
    assert "Speed-up at equal quality" in markdown and "Full resolution: cornell-box at 48x32" in markdown
    section = readme_section(record)
    assert "adaptive path tracing + OIDN" in section and "equal time (budgets" in section
    assert "1 real and 1 synthetic scenes" in section and "| 1 real |" in section and "| all 2 |" in section
    for heading in ("Table 1", "Table 2", "Fig. 10", "Fig. 12", "Table 3", "Crossover", "Table 4"):
        assert heading in markdown
    assert "pawnnm - nnm" in markdown
    assert markdown.startswith("# Results\n\n## At a glance\n") and "(psnr_vs_time_groups.png)" in markdown
    for png in ("psnr_vs_time.png", "psnr_vs_rate.png", "psnr_vs_time_groups.png", "grid-cornell-box.png",
                "grid-proc-2000003.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "docs/psnr_vs_time_groups.png" in readme_section(record)
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
    (["--from", "nope.json", "--no-readme", "--out", "/tmp"], "--from nope.json: No such file or directory"),
    (["--from", "README.md", "--no-readme", "--out", "/tmp"], "--from README.md is not JSON"),
])
def test_eval_bad_input_is_one_line(args, message):
    result = _eval(*args)
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_time_to_reach_interpolates_on_the_frontier_in_log_time():
    from gmcpt.evaluation.report import speedup, time_to_reach

    # path+oidn: 20 dB at 1 s, 26 at 2 s, 30 at 4 s; a slower setting that scores worse does not lower the frontier
    rows = ROWS + [_row("s", "path+oidn", 8, 8.0, 29.0)]
    assert time_to_reach(rows, "path+oidn", 23.0) == ("=", pytest.approx(2 ** 0.5))
    assert time_to_reach(rows, "path+oidn", 30.0) == ("=", pytest.approx(4.0))
    assert time_to_reach(rows, "path+oidn", 19.0) == ("<", 1.0)
    assert time_to_reach(rows, "path+oidn", 31.0) == (">", 8.0)
    assert time_to_reach(rows, "nobody", 20.0) is None
    # m's 22 dB at 1.5 s: path+oidn needs 2 ** (1/3) s for it
    assert speedup(rows, ROWS[4], "path+oidn") == ("=", pytest.approx(2 ** (1 / 3) / 1.5))


def test_group_means_split_real_and_synthetic_scenes():
    from gmcpt.evaluation.report import groups, variant_table

    rows = [{"scene": s, "real": s.startswith("r"), "variant": "v", "rate": 0.3, "psnr": p, "flip": 0.1}
            for s, p in (("r1", 30.0), ("r2", 32.0), ("s1", 20.0))]
    assert [label for label, _ in groups(rows)] == ["r1", "r2", "s1", "**mean of 2 real**", "**mean of 1 synthetic**",
                                                    "**mean of 3**"]
    table = variant_table(rows, ["v"], ["psnr"], [0.3])
    assert "| **mean of 2 real** | 30% | 31.00 |" in table and "| **mean of 1 synthetic** | 30% | 20.00 |" in table
    assert "| **mean of 3** | 30% | 27.33 |" in table


def test_readme_means_are_groups_not_scenes():
    """Without real scenes (a fresh clone) the README's table has the overall mean only, never single scenes."""
    from gmcpt.evaluation.document import readme_section

    placement = [{"scene": s, "real": False, "variant": v, "rate": 0.3, "psnr": p}
                 for s in ("a", "b", "c") for v, p in (("path+oidn", 30.0), ("adaptive+oidn", 31.0), ("budget", 30.5))]
    run = {"config": {"rates": [0.3], "spp": 16, "mask": "two_pass", "default_placement": "budget",
                      "placement_variant": "gan_oidn", "resolution": 256, "reference_spp": 4096, "seed": 0},
           "placement": placement, "equal_time": [], "quality": placement, "command": "eval", "date": "today"}
    rows = [line for line in readme_section(run).splitlines() if line.startswith("| ")][1:]
    assert len(rows) == 1 and rows[0].startswith("| all 3 | -0.50 |")


RESULTS = ROOT / "docs" / "results.json"


def test_results_open_at_a_glance_and_the_readme_limits_are_generated():
    """On the recorded run: the at-a-glance table's equal-time figures are the speed-up table's (one function), the
    README's limits are what the record gives, between their markers, and the README holds them as generated."""
    from gmcpt.evaluation.document import results_markdown, rewrite_readme
    from gmcpt.evaluation.glance import LIMITS_END, LIMITS_START, glance_table, readme_limits
    from gmcpt.evaluation.report import speedup_table

    run = json.loads(RESULTS.read_text())
    markdown = results_markdown(run)
    assert markdown.startswith("# Results\n\n## At a glance\n")
    assert markdown.index("(psnr_vs_time_groups.png)") < markdown.index("## References and their noise")
    table = glance_table(run).splitlines()
    assert [line.split("|")[1].strip() for line in table[2:]] == ["5 real", "4 synthetic", "all 9"]
    speedups = speedup_table(run["equal_time"], "gan_oidn").splitlines()
    for line, group in zip(table[2:], ("5 real", "4 synthetic", "9")):
        better = next(s for s in speedups if f"mean of {group}**" in s and "better of the two" in s)
        assert line.split("|")[-2].strip() == better.split("|")[-2].strip()
    limits = readme_limits(run)
    scenes = [line.split("|") for line in speedups if "better of the two" in line and "**" not in line]
    ratios = sorted(float(cells[-2].strip().split("x")[0].lstrip("<>")) for cells in scenes)
    assert f"{ratios[0]:.2f}-{ratios[-1]:.2f}x a scene" in limits  # the scenes' range of the speed-up table
    readme = (ROOT / "README.md").read_text()
    assert limits in readme, "the README's limits are not the ones docs/results.json gives: gmcpt eval --from"
    rewritten = rewrite_readme(f"# T\n\n## Limits\n\n{LIMITS_START}\nSTALE\n{LIMITS_END}\n\n## Layout\n", run)
    assert "STALE" not in rewritten and f"## Limits\n\n{limits}\n\n## Layout\n" in rewritten


def test_eval_from_a_record_rewrites_the_documents_and_a_sequence_record_beside_gets_its_section(tmp_path):
    """``gmcpt eval --from``: results.md, its plots and the README's sections from the recorded run, and from a
    sequence record beside the results its own section (one run of the command: its plots take 15 s)."""
    from gmcpt.evaluation.glance import readme_limits
    from gmcpt.evaluation.plots import sequence_plot

    rows = [{"scene": "living-room", "contender": contender, "spp": spp, "psnr": psnr, "seconds": seconds,
             "flicker": flicker, "rate": 1.0}
            for contender, spp, psnr, seconds, flicker in [("path+oidn", 1, 22.1, 0.20, 9.5),
                                                           ("path+oidn", 2, 23.4, 0.27, 8.9),
                                                           ("sequence", 1, 23.9, 0.21, 6.1)]]
    rows[2].update(flip=0.08, screen_flicker=8.2)  # a record from before FLIP and the in-place figure has neither
    sequences = {"command": "python benchmarks/sequence.py --record x", "date": "2026-11-27", "commit": "abc",
                 "machine": "x86_64, 2 cores", "settings": {"frames": 10, "motion": "pan", "step": 0.5, "res": 256,
                                                           "reference_spp": 512, "warm": 3},
                 "rows": rows, "verdicts": [{"scene": "living-room", "baseline": "path+oidn", "speedup": 1.61,
                                             "bounds": 0, "settings": 1, "flicker_ratio": 0.66,
                                             "screen_flicker_ratio": 0.81}]}
    (tmp_path / "sequences.json").write_text(json.dumps(sequences))
    sequence_plot(rows, tmp_path / "sequences.png")
    readme = tmp_path / "README.md"
    readme.write_text("# T\n")
    result = _eval("--from", str(RESULTS), "--out", str(tmp_path), "--readme", str(readme), "-q")
    assert result.returncode == 0, result.stderr
    markdown = (tmp_path / "results.md").read_text()
    assert markdown.startswith("# Results\n\n## At a glance")
    assert (tmp_path / "psnr_vs_time_groups.png").read_bytes()[:4] == b"\x89PNG"
    text = readme.read_text()
    assert "## Results" in text and "## Limits" in text and readme_limits(json.loads(RESULTS.read_text())) in text
    assert not (tmp_path / "results.json").exists()  # a rewrite measures nothing and records nothing new
    assert "## Sequences" in markdown
    assert "| living-room | sequence | 1 | 23.90 | - | 0.0800 | 0.210 | 6.10 (8.20) |" in markdown
    assert "| living-room | path+oidn | 1 | 22.10 | - | - | 0.200 | 9.50 |" in markdown
    assert "| living-room | path+oidn | 1.61x | 0.66 (0.81) | - |" in markdown and "(sequences.png)" in markdown
    assert "## At a glance\n\n**Sequences** (`benchmarks/sequence.py`, 1 scenes at 256x256): " in markdown
    assert (tmp_path / "sequences.png").read_bytes()[:4] == b"\x89PNG"


def test_equal_time_rounds_warm_up_before_they_time_and_count():
    """The warm-up round runs every setting once, untimed and uncounted (a first run compiles; the default's first
    frames read the scene); quality is the mean over the counted runs, time the fastest of them."""
    import time

    from gmcpt.evaluation import measure

    reference = np.zeros((8, 8, 3), np.float32)
    calls = []

    def run(index):
        calls.append(index)
        if index == 0:
            time.sleep(0.05)  # a cold first run: its time, as its image, must not count
            return (np.full((8, 8, 3), 10.0, np.float32),)
        return (np.full((8, 8, 3), 0.1 * index, np.float32),)

    setting = measure._Setting({}, run)
    done = []
    measure._in_rounds([setting], 3, reference, lambda s, result: done.append(result))
    counted = list(range(measure.WARM_UP_ROUNDS, measure.all_rounds(3)))
    assert calls[:measure.WARM_UP_ROUNDS] == list(range(measure.WARM_UP_ROUNDS)) and len(done) == 1
    assert len(setting.metrics) == measure.timed_runs(3) == len(counted)
    expected = np.mean([measure.all_metrics(np.full((8, 8, 3), 0.1 * i, np.float32), reference)["mse"]
                        for i in counted])
    assert np.isclose(np.mean([m["mse"] for m in setting.metrics]), expected)
    assert set(calls[measure.WARM_UP_ROUNDS:]) <= set(counted) and setting.seconds < 0.05
    # a cheap setting: every counted round and every extra timing run has its time, by round
    assert sorted(setting.times) == list(range(measure.timing_rounds(3)))
    assert setting.seconds == np.median(list(setting.times.values()))


def test_the_speedup_pairs_the_runs_of_one_round():
    """By hand: the default's 26 dB is path+oidn's 2-spp setting. Round 0 ran slow for both (2.0 s against 2.2 s),
    rounds 1 and 2 fast; ratios 0.909, 0.909 and 1.1: the median is 0.909x, where the fastest runs would say 1.0x.
    A baseline setting that missed a round counts at its median; of an even number of ratios the lower middle."""
    from gmcpt.evaluation import report

    def row(contender, psnr, times, spp=1):
        return {"scene": "s", "contender": contender, "rate": 1.0, "spp": spp, "psnr": psnr,
                "seconds": float(np.median([t for t in times if t is not None])), "round_seconds": times}

    rows = [row("path+oidn", 20.0, [1.0, 0.5, 0.5]), row("path+oidn", 26.0, [2.0, 1.0, 1.1], spp=2),
            row("path+oidn", 30.0, [4.0, None, 2.0], spp=4), row("gan_oidn", 26.0, [2.2, 1.1, 1.0], spp=16)]
    bound, ratio = report.speedup(rows, rows[-1], "path+oidn")
    assert bound == "=" and ratio == pytest.approx(1.0 / 1.1)
    # 28 dB lies halfway in log time between the 2- and 4-spp settings; round 1 takes the 4-spp one's median 3 s
    two = dict(rows[-1], psnr=28.0, round_seconds=[4.0, 2.0])
    expected = sorted([np.sqrt(2.0 * 4.0) / 4.0, np.sqrt(1.0 * 3.0) / 2.0])[0]
    assert report.speedup(rows, two, "path+oidn")[1] == pytest.approx(expected)
    # rows without round times (an older results.json): each setting's own time
    plain = [{k: v for k, v in r.items() if k != "round_seconds"} for r in rows]
    assert report.speedup(plain, plain[-1], "path+oidn")[1] == pytest.approx(1.1 / 1.1)


def test_a_setting_that_reads_its_scene_twice_warms_up_twice_and_counts_neither():
    """The default's readings wait on one another: its warm-up runs both reading frames, and only what follows counts."""
    from gmcpt.evaluation import measure

    images = {0: 10.0, 1: 5.0}  # the two reading frames of the warm-up, far from the reference
    calls = []

    def run(index):
        calls.append(index)
        return (np.full((8, 8, 3), images.pop(len(calls) - 1, 0.0), np.float32),)

    setting = measure._Setting({}, run, warm_ups=2)
    measure._in_rounds([setting], 3, np.zeros((8, 8, 3), np.float32), lambda s, result: None)
    assert calls[:2] == [0, 0] and len(setting.metrics) == measure.timed_runs(3)
    assert all(m["mse"] == 0.0 for m in setting.metrics)


def test_at_equal_time_both_baselines_draw_the_defaults_seeds(monkeypatch):
    """Common random numbers: in each run, path tracing + OIDN and adaptive path tracing + OIDN render and take
    their guides with the seed of the default's frame, so that a dense frame is the same render as a baseline's
    and the contenders differ by what they do, not by one seed's luck."""
    import gmcpt.pipeline
    from gmcpt.evaluation import measure
    from gmcpt.evaluation.config import DEFAULT_VARIANT, QUICK

    seeds = {"path": [], "adaptive": [], "guides": [], "default": []}
    image = np.full((16, 16, 3), 0.5, np.float32)

    def path_oidn(loaded, spp, seed, guides):
        seeds["path"].append(seed)
        return image, image, {"render_s": 0.0}

    def adaptive_oidn(loaded, budget, seed, guides):
        from gmcpt.sampling.adaptive import AdaptiveInfo

        seeds["adaptive"].append(seed)
        samples = np.full(image.shape[:2], int(budget))
        return image, AdaptiveInfo(budget, int(samples.sum()), samples, 0), {}

    def render_and_complete(scene, integrator, settings, method, options):
        from gmcpt.frame import FrameInfo

        seeds["default"].append(settings.seed)
        frame = type("Frame", (), {"info": FrameInfo(path_samples=16 * settings.budget, budget_choice="dense")})
        return type("Rendered", (), {"image": image, "frame": frame})

    monkeypatch.setattr(measure, "_path_oidn", path_oidn)
    monkeypatch.setattr(measure, "adaptive_oidn", adaptive_oidn)
    monkeypatch.setattr(measure, "baseline_guides", lambda loaded, spp, seed: seeds["guides"].append(seed))
    monkeypatch.setattr(measure, "guide_pass_seconds", lambda loaded, spp, seed: seeds["guides"].append(seed))
    monkeypatch.setattr(gmcpt.pipeline, "render_and_complete", render_and_complete)
    config = dataclasses.replace(QUICK, path_spp=(4,), adaptive_budgets=(4,), budget_variants=(DEFAULT_VARIANT,),
                                 default_budgets=(4,), seed=3)
    loaded = measure.LoadedScene("s", None, None, image)
    measure.equal_time(loaded, config, lambda message: None)
    runs = set(seeds["default"])
    assert len(runs) == measure.all_rounds(config.repeats) and min(runs) == 3
    assert set(seeds["path"]) == set(seeds["adaptive"]) == set(seeds["guides"]) == runs


def test_an_interrupted_evaluation_resumes_after_its_last_finished_scene(tmp_path, monkeypatch):
    """The checkpoint keeps each finished scene; a run with the same key measures only the rest, one with another
    key (other code or configuration) starts over, and uncommitted code never checkpoints."""
    from types import SimpleNamespace

    from gmcpt.evaluation import checkpoint, measure, plots
    from gmcpt.cli.eval import evaluate
    from gmcpt.evaluation.config import CONFIGS

    measured = []

    def load(scene, config, say):
        if scene.name == "b" and len(measured) == 1 and interrupt:
            raise KeyboardInterrupt
        measured.append(scene.name)
        return SimpleNamespace(images={}), {"scene": scene.name}

    rows = lambda loaded, config, say: [{"scene": measured[-1]}]  # noqa: E731
    for name in ("quality", "placement", "equal_time", "stage_timings"):
        monkeypatch.setattr(measure, name, rows if name != "stage_timings" else lambda s, c, say: [])
    monkeypatch.setattr(measure, "load", load)
    monkeypatch.setattr(measure, "full_resolution", lambda scene, config, say: [{"full": scene.name}])
    monkeypatch.setattr(plots, "image_grid", lambda *args: None)
    monkeypatch.setattr(plots, "write_plots", lambda record, out: None)
    scenes = [SimpleNamespace(name=name, real=False, credit=None) for name in ("a", "b")]
    config = CONFIGS["quick"]
    key = checkpoint.resume_key(config, scenes, "c0ffee")
    interrupt = True
    with pytest.raises(KeyboardInterrupt):
        evaluate(config, scenes, tmp_path, lambda message: None, quiet=True, resume=key)
    assert measured == ["a"] and (tmp_path / checkpoint.PARTIAL).is_file()
    interrupt = False
    said = []
    record = evaluate(config, scenes, tmp_path, said.append, quiet=True, resume=key)
    assert measured == ["a", "b"] and any("resuming" in line and "a measured" in line for line in said)
    assert [r["scene"] for r in record["quality"]] == ["a", "b"] and record["runs"] == 2
    assert record["full_resolution"] == [] and record["done"] == ["a", "b"]  # the quick config's sponza is absent
    other = checkpoint.resume_key(config, scenes, "decaf")
    evaluate(config, scenes, tmp_path, lambda message: None, quiet=True, resume=other)
    assert measured == ["a", "b", "a", "b"]
    assert checkpoint.resume_key(config, scenes, None) is None


def test_a_checkpoint_needs_committed_code(tmp_path):
    from gmcpt.evaluation.checkpoint import code_version

    assert code_version(tmp_path) is None  # no git here


def test_path_tracing_at_equal_samples_reads_between_whole_counts(monkeypatch):
    """Between two whole sample counts the uniform baseline's metrics are read linearly in log samples; at a whole
    count it is that count's render alone."""
    from gmcpt.evaluation import measure

    rendered = []

    def render_full(scene, integrator, spp, seed):
        rendered.append((spp, seed))
        return np.full((2, 2, 3), float(spp) + seed / 100, np.float32)

    monkeypatch.setattr(measure, "render_full", render_full)
    monkeypatch.setattr(measure, "denoise_oidn", lambda image, albedo, normal, rays: image + albedo)
    monkeypatch.setattr(measure, "all_metrics", lambda image, reference: {"psnr": float(image.mean())})
    loaded = measure.LoadedScene("s", None, None, np.zeros((2, 2, 3), np.float32))
    # each seed's own guides (an albedo of 10 x the seed here, which the stand-in denoiser adds)
    guides = {seed: {count: {"albedo": np.float32(10 * seed), "normal": None} for count in (1, 4, 5)}
              for seed in (0, 1)}
    assert [run["psnr"] for run in measure.path_oidn_at(loaded, 4.0, [0, 1], guides)] == pytest.approx([4.0, 14.01])
    assert sorted(rendered) == [(4, 0), (4, 1)]
    weight = np.log(4.8 / 4) / np.log(5 / 4)
    assert measure.path_oidn_at(loaded, 4.8, [0], guides)[0]["psnr"] == pytest.approx(4 + weight)
    assert measure.path_oidn_at(loaded, 0.5, [0], guides)[0]["psnr"] == pytest.approx(1.0)  # below one: one sample
    # the adaptive baseline's guide rays are always one of the two counts, whose guide pass (of its seed) it shares
    assert all(measure.baseline_guide_rays(s) in measure.whole_counts(s) for s in (0.5, 1, 3.2, 4.5, 4.8, 6.4, 8))
