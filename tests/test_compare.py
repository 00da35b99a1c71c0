"""``gmcpt compare`` on a scene that is not shipped, its refusals, and the verdict it shares with the evaluation."""
import json
import math
import os
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT

#: the README's example (proposed for its "Command line"); the test runs it with its own scene for the shipped one
EXAMPLE = """gmcpt reference scenes/cornell-box/scene.xml --spp 256 --res 64 64 --out out/ref64.exr
gmcpt compare scenes/cornell-box/scene.xml --reference out/ref64.exr --res 64 64 --budgets 2 4 --out out/compare
"""

#: a scene no test ships: a diffuse box on a floor under an area light, the plain ``path`` integrator
BOX = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <shape type="cube">
        <transform name="to_world"><scale value="0.5"/><translate value="0, 0.5, 0"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.4, 0.2"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/><translate value="0, 2.5, 0"/></transform>
        <emitter type="area"><rgb name="radiance" value="6, 6, 6"/></emitter>
    </shape>
</scene>
"""


def _environment(tmp_path):
    """A cache of the test's own for the references; the generator's conversions stay the user's (each is 10-17 s
    of a process that would import torch for it, and not what these tests check)."""
    from gmcpt.gan import runtime

    generators, cache = runtime.cache_dir(), tmp_path / "cache"
    if not (cache / "generators").exists():
        generators.mkdir(parents=True, exist_ok=True)
        cache.mkdir(exist_ok=True)
        (cache / "generators").symlink_to(generators, target_is_directory=True)
    return {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
            "PYTHONPATH": str(ROOT), "PYTHONWARNINGS": "ignore", "GMCPT_CACHE": str(cache)}


def _compare(tmp_path, *args):
    return subprocess.run([sys.executable, "-m", "gmcpt", "compare", *map(str, args)], capture_output=True,
                          text=True, cwd=tmp_path, env=_environment(tmp_path), timeout=300)


def _rows():
    """Hand-made equal-time rows of one scene: path+oidn 20/26/30 dB at 1/2/4 s, adaptive+oidn 24/28 dB at
    1.5/3 s, the default 26 dB at 1.5 s (budget 2) and 29 dB at 2 s (budget 4)."""
    row = lambda contender, seconds, psnr, rate=1.0, spp=1, **extra: {  # noqa: E731
        "scene": "s", "contender": contender, "rate": rate, "spp": spp, "samples_per_pixel": rate * spp,
        "seconds": seconds, "psnr": psnr, "ssim": 0.9, "flip": 0.1, "mse": 0.01, "relmse": 0.1, **extra}
    return [row("path", 0.5, 15.0, spp=1), row("path+oidn", 1.0, 20.0, spp=1), row("path+oidn", 2.0, 26.0, spp=2),
            row("path+oidn", 4.0, 30.0, spp=4), row("adaptive+oidn", 1.5, 24.0, spp=2),
            row("adaptive+oidn", 3.0, 28.0, spp=4),
            row("gan_oidn", 1.5, 26.0, rate=2 / 16, spp=16, budget_choice="sparse"),
            row("gan_oidn", 2.0, 29.0, rate=4 / 16, spp=16, budget_choice="dense")]


def test_the_verdict_is_one_function_of_the_rows():
    """By hand: the default's 26 dB takes path+oidn 2 s (1.33x its 1.5 s) and adaptive sqrt(1.5 x 3) s (1.41x):
    the better baseline gives 1.33x. Its 29 dB takes path+oidn 2 x 2^0.75 s (1.68x) and adaptive more than its
    slowest 3 s (a bound, >1.5x): 1.5x. Geometric mean sqrt(1.33 x 1.5) = 1.41x, one ratio a bound."""
    from gmcpt.evaluation import compare_report, report

    rows = _rows()
    verdict = report.equal_time_verdict(rows, "gan_oidn")
    assert verdict["speedup"] == pytest.approx(math.sqrt(2 / 1.5 * 3 / 2))
    assert (verdict["settings"], verdict["bounds"]) == (2, 1)
    assert [bound for bound, _ in verdict["ratios"]] == ["=", ">"]
    assert report.better_speedup(rows, rows[-1], ("adaptive+oidn",)) == (">", 1.5)
    assert report.better_speedup(rows, rows[-1], ("path+oidn",))[1] == pytest.approx(2 * 2 ** 0.75 / 2)
    # the evaluation's speed-up table and compare's verdict line say the same number
    table = report.speedup_table(rows, "gan_oidn")
    better = next(line for line in table.splitlines() if "the better of the two" in line)
    assert better.endswith("| 1.33x | >1.50x | 1.41x (1 bound) |"), better
    found, line = compare_report.verdict(rows)
    assert found == verdict
    assert line == ("verdict: gan_oidn is 1.41x faster than the better baseline at equal quality (geometric mean "
                    "over budgets 2, 4; 1 of 2 ratios is only a bound)")
    budgets = compare_report.per_budget(rows)
    assert [b["budget"] for b in budgets] == [2, 4]
    assert budgets[0]["better_speedup"] == {"bound": "=", "ratio": pytest.approx(2 / 1.5)}
    assert budgets[0]["equal_samples"]["path+oidn"]["psnr"] == 26.0  # path at 2 spp
    assert budgets[1]["equal_time"]["adaptive+oidn"]["psnr"] == 24.0  # within 2 s: its 1.5-s setting
    slower = [dict(r, seconds=r["seconds"] * 4) if r["contender"] == "gan_oidn" else r for r in rows]
    assert "the better baseline is" in compare_report.verdict(slower)[1]


def test_compare_config_is_the_evaluations_restricted_to_the_budgets():
    from gmcpt.evaluation.compare_report import compare_config, path_ladder
    from gmcpt.evaluation.config import QUICK

    config = compare_config([4, 2, 8, 2], seed=5)
    changed = {key for key, value in asdict(config).items() if asdict(QUICK)[key] != value}
    assert changed <= {"name", "seed", "default_budgets", "path_spp", "adaptive_budgets", "budget_variants"}
    assert config.default_budgets == (2, 4, 8) and config.budget_variants == ("gan_oidn",) and config.seed == 5
    assert config.path_spp == (1, 2, 4, 8, 16) and config.adaptive_budgets == (2, 4, 8, 16)
    assert path_ladder([3]) == (1, 2, 3, 4)  # a budget's own count, for equal samples


@pytest.mark.slow  # 37 s: make test runs compare end to end twice below (a reference, then its cache), and checks
# the README holds EXAMPLE
def test_compare_on_a_scene_that_is_not_shipped(tmp_path):
    """The README's example, verbatim but for the scene: a reference, then the comparison, with the outputs."""
    (tmp_path / "box.xml").write_text(BOX)
    (tmp_path / "out").mkdir()
    script = EXAMPLE.replace("scenes/cornell-box/scene.xml", "box.xml")
    result = subprocess.run(["bash", "-e", "-c", script], capture_output=True, text=True, cwd=tmp_path,
                            env=_environment(tmp_path), timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    out = tmp_path / "out" / "compare"
    record = json.loads((out / "compare.json").read_text())
    assert [b["budget"] for b in record["budgets"]] == [2, 4]
    assert {r["contender"] for r in record["rows"]} == {"path", "path+oidn", "adaptive+oidn", "gan_oidn"}
    assert {r["spp"] for r in record["rows"] if r["contender"] == "path+oidn"} == {1, 2, 4, 8}
    assert all(r["seconds"] > 0 and 10 < r["psnr"] < 60 for r in record["rows"])
    assert record["size"] == [64, 64] and record["reference"].endswith("ref64.exr")
    assert record["config"]["default_budgets"] == [2, 4] and "versions" in record and record["seconds"] > 0
    from gmcpt.evaluation import compare_report

    assert compare_report.verdict(record["rows"])[1] == record["verdict_line"]  # the JSON holds every figure
    for png in ("psnr_vs_time.png", "images.png"):
        assert (out / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    lines = result.stdout.splitlines()
    assert lines[-1] == record["verdict_line"] and lines[-1].startswith("verdict: ") and "faster" in lines[-1]
    assert lines[0].startswith("| budget (spp) |") and sum(line.startswith("| 2 |") for line in lines) == 1
    assert "left]" in result.stderr and "Traceback" not in result.stderr
    # the same rows in an evaluation's speed-up table: the verdict there is the verdict here
    from gmcpt.evaluation.report import speedup_table

    cell = f"{record['verdict']['speedup']:.2f}x"
    better = next(line for line in speedup_table(record["rows"], "gan_oidn").splitlines() if "better of the two" in line)
    assert better.split("|")[-2].strip().startswith(cell)


@pytest.mark.slow  # 33 s: test_the_verdict_is_one_function_of_the_rows checks the same function on rows it writes
def test_the_verdict_agrees_with_the_evaluation_on_a_shipped_scene(tmp_path):
    """On the Cornell box: compare runs the evaluation's settings but for the budgets, and the evaluation's
    documents (the speed-up table, the table at a glance) give its rows the verdict compare printed."""
    from conftest import CORNELL
    from gmcpt.evaluation.config import QUICK
    from gmcpt.evaluation.glance import glance_table
    from gmcpt.evaluation.report import equal_time_verdict, speedup_table

    result = _compare(tmp_path, CORNELL, "--res", "32", "32", "--budgets", "1", "2", "--reference-spp", "16",
                      "--out", "c")
    assert result.returncode == 0, result.stderr[-3000:]
    record = json.loads((tmp_path / "c" / "compare.json").read_text())
    quick = json.loads(json.dumps(asdict(QUICK)))
    changed = {key for key, value in record["config"].items() if quick[key] != value}
    assert changed <= {"name", "default_budgets", "path_spp", "adaptive_budgets", "budget_variants"}
    rows = record["rows"]
    assert json.loads(json.dumps(equal_time_verdict(rows, "gan_oidn"))) == record["verdict"]
    cell = f"{record['verdict']['speedup']:.2f}x"
    better = next(line for line in speedup_table(rows, "gan_oidn").splitlines() if "better of the two" in line)
    assert better.split("|")[-2].strip().startswith(cell)
    run = {"config": record["config"], "equal_time": [dict(r, real=False) for r in rows], "placement": []}
    assert glance_table(run).splitlines()[2].split("|")[-2].strip().startswith(cell)
    ratio = record["verdict"]["speedup"]
    assert f"{ratio if ratio >= 1 else 1 / ratio:.2f}x faster" in result.stdout.splitlines()[-1]


def test_readme_example_is_this_one():
    readme = (ROOT / "README.md").read_text()
    if "gmcpt compare" not in readme:
        pytest.skip("the README has no compare example yet")
    assert EXAMPLE in readme


def test_reference_rendered_once_then_cached(tmp_path):
    (tmp_path / "box.xml").write_text(BOX)
    args = ["box.xml", "--budgets", "1", "--reference-spp", "16", "--out", "first"]
    first = _compare(tmp_path, *args)
    assert first.returncode == 0, first.stderr[-3000:]
    assert "reference 1/1 pass" in first.stderr and "rendered and cached" in first.stderr
    second = _compare(tmp_path, *args[:-1], "second")
    assert second.returncode == 0 and "from the cache" in second.stderr
    assert json.loads((tmp_path / "second" / "compare.json").read_text())["reference_spp"] == 16


@pytest.mark.parametrize("args, message", [
    (["nope.xml"], "scene file not found: nope.xml"),
    (["."], ". is a folder: give the scene XML in it"),
    (["box.xml", "--budgets", "0.5"], "--budgets must each be in [1, 32]"),
    (["box.xml", "--budgets", "64"], "--budgets must each be in [1, 32]"),
    (["box.xml", "--budgets", "nan"], "--budgets must each be in [1, 32]"),
    (["box.xml", "--budgets", "two"], "invalid float value"),
    (["box.xml", "--reference", "missing.exr"], "reference not found: missing.exr"),
    (["box.xml", "--reference", "box.xml"], "cannot read EXR box.xml"),
    (["box.xml", "--reference", "small.exr"], "small.exr is 8x8, the film is 32x32"),
    (["box.xml", "--seed", "-1"], "--seed must be"),
])
def test_bad_input_is_one_line(tmp_path, args, message):
    from gmcpt.exr import write_exr

    (tmp_path / "box.xml").write_text(BOX)
    write_exr(tmp_path / "small.exr", {c: np.ones((8, 8), np.float32) for c in "RGB"})
    result = _compare(tmp_path, *args)
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith("error: ") and len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert message in result.stderr
    assert not (tmp_path / "compare-box").exists()
