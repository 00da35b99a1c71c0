"""gmcpt regress on a fresh suite of two scenes this project never saw (built here as XML strings)."""
import json
import re
import shutil
import subprocess
import sys

import pytest

from conftest import ROOT

RED, GREEN = "0.7, 0.08, 0.06", "0.1, 0.6, 0.1"
FRAME_WIDTH = 2 * 3.5 * 0.364  # the frame's width at the sphere (3.5 from a camera with a 40-degree fov), about 2.5


def camera(fov, origin, target, size, max_depth):
    """The scene's opening: a path integrator and a square perspective camera."""
    return f"""<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="{size}"/><integer name="height" value="{size}"/>
      <rfilter type="box"/></film>
  </sensor>
"""


def box_scene(wall=RED, light=10.0, sphere_x=0.3, size=64):
    """A box with a coloured left wall, a ceiling light and a white sphere."""
    return camera(40, "0, 0, 3.6", "0, 0, 0", size, 6) + f"""
  <bsdf type="diffuse" id="white"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
  <bsdf type="diffuse" id="wall"><rgb name="reflectance" value="{wall}"/></bsdf>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1"/></transform>
    <ref id="white"/></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="1"/></transform>
    <ref id="white"/></shape>
  <shape type="rectangle"><transform name="to_world"><translate z="-1"/></transform><ref id="white"/></shape>
  <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="90"/><translate x="-1"/></transform>
    <ref id="wall"/></shape>
  <shape type="rectangle"><transform name="to_world"><rotate y="1" angle="-90"/><translate x="1"/></transform>
    <ref id="white"/></shape>
  <shape type="rectangle">
    <transform name="to_world"><scale x="0.35" y="0.35"/><rotate x="1" angle="90"/><translate y="0.99"/></transform>
    <emitter type="area"><rgb name="radiance" value="{light}, {light}, {light}"/></emitter>
  </shape>
  <shape type="sphere"><point name="center" x="{sphere_x}" y="-0.6" z="0.1"/><float name="radius" value="0.4"/>
    <ref id="white"/></shape>
</scene>
"""


def table_scene(size=64):
    """A yellow cube and a blue glossy sphere on a grey floor, an area light and a dim sky."""
    return camera(45, "0, 2, 5", "0, 0.3, 0", size, 5) + """
  <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.5, 0.5"/></bsdf></shape>
  <shape type="cube"><transform name="to_world"><scale value="0.45"/><rotate y="1" angle="30"/>
    <translate x="-0.7" y="0.45"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.7, 0.1"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.8" y="0.5" z="0.3"/><float name="radius" value="0.5"/>
    <bsdf type="roughplastic"><float name="alpha" value="0.1"/>
      <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.6"/></bsdf></shape>
  <shape type="rectangle"><transform name="to_world"><scale value="0.8"/>
    <lookat origin="2, 3.5, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <emitter type="area"><rgb name="radiance" value="8, 8, 8"/></emitter></shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.1, 0.12"/></emitter>
</scene>
"""


def write_suite(folder, box=None):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "box.xml").write_text(box or box_scene())
    (folder / "table.xml").write_text(table_scene())
    return folder


def run_regress(*args):
    return subprocess.run([sys.executable, "-m", "gmcpt", "regress", *map(str, args)], capture_output=True,
                          text=True, cwd=ROOT, timeout=600)


@pytest.fixture(scope="module")
def suite(tmp_path_factory, mi):
    """A two-scene suite with goldens (256 spp) made in this process."""
    from gmcpt.regress import update_suite

    folder = write_suite(tmp_path_factory.mktemp("suite"))
    update_suite(folder, golden_spp=256)
    return folder


def changed(suite, tmp_path, **box):
    """A copy of ``suite`` (goldens included) whose box scene is built with ``box`` changed."""
    copy = tmp_path / "changed"
    shutil.copytree(suite, copy)
    (copy / "box.xml").write_text(box_scene(**box))
    return copy


@pytest.mark.slow  # 45 s: make test runs the README's regress example and the reports of test_pytest_helper_*
def test_update_then_check_passes_and_a_recoloured_wall_fails_alone(tmp_path):
    folder = write_suite(tmp_path / "fresh")
    update = run_regress(folder, "--update", "--golden-spp", "256")
    assert update.returncode == 0, update.stderr
    manifest = json.loads((folder / "golden" / "manifest.json").read_text())
    assert set(manifest["scenes"]) == {"box", "table"} and manifest["settings"]["golden_spp"] == 256
    assert (folder / "golden" / "box.exr").is_file() and (folder / "golden" / "table.exr").is_file()

    check = run_regress(folder)
    assert check.returncode == 0, check.stdout + check.stderr
    lines = check.stdout.splitlines()
    assert [line.split()[0] for line in lines[:2]] == ["box", "table"]
    assert all(line.endswith("pass") and "check" in line and "golden" in line for line in lines[:2])
    assert lines[2].startswith("2 checked: 2 passed, 0 FAILED") and "goldens took" in lines[2]

    (folder / "box.xml").write_text(box_scene(wall=GREEN))
    report = tmp_path / "report.html"
    check = run_regress(folder, "--report", report)
    assert check.returncode == 1, check.stdout + check.stderr
    box_line, table_line, summary = check.stdout.splitlines()
    assert box_line.startswith("box") and box_line.endswith("FAIL")
    assert table_line.startswith("table") and table_line.endswith("pass")
    assert "1 FAILED (box)" in summary and str(report) in summary
    page = report.read_text()
    sections = re.findall(r'<section class="(\w+)"><h2>(\w+): (\w+)</h2>', page)
    assert sections == [("fail", "box", "FAIL"), ("pass", "table", "pass")]  # failed scene first
    box_part = page[page.index("<h2>box"):page.index("<h2>table")]
    assert box_part.count('src="data:image/png;base64,') == 3  # golden, check, FLIP map
    assert "src=\"http" not in page and "<link" not in page  # self-contained


def test_unchanged_scenes_pass_on_ten_seeds(suite):
    from gmcpt.regress import check_suite

    for seed in range(10):
        results = check_suite(suite, seed=seed)
        assert all(result.passed for result in results), [(r.name, r.metrics, r.thresholds) for r in results]


@pytest.mark.parametrize("change", [{"light": 12.0}, {"sphere_x": 0.3 + 0.05 * FRAME_WIDTH}],
                         ids=["light+20%", "moved-5%"])
def test_small_visible_change_fails(suite, tmp_path, change):
    from gmcpt.regress import check_suite

    [result] = check_suite(changed(suite, tmp_path, **change), ["box"])
    assert not result.passed and "block_psnr" in result.failed


def test_same_seed_same_result(suite):
    from gmcpt.regress import check_suite

    first, second = check_suite(suite, ["table"], seed=3), check_suite(suite, ["table"], seed=3)
    assert first[0].metrics == second[0].metrics


def test_pytest_helper_one_case_per_scene_and_a_failure_naming_metric_threshold_report(suite, tmp_path):
    from gmcpt.regress import assert_scene, pytest_cases

    cases = pytest_cases(suite)
    assert [case.id for case in cases] == ["box", "table"] and not any(case.marks for case in cases)
    assert assert_scene(cases[1].values[0]).passed
    [case] = pytest_cases(changed(suite, tmp_path, wall=GREEN), ["box"])
    with pytest.raises(AssertionError) as failure:
        assert_scene(case.values[0], report_dir=tmp_path / "reports")
    message = str(failure.value)
    assert "scene box regressed" in message and "block PSNR" in message and "threshold >=" in message
    report = message.rsplit("report ", 1)[1]
    assert report.endswith("changed-box.html") and "data:image/png;base64," in open(report).read()


def test_optional_scene_outside_the_folder_is_skipped_with_its_reason(suite, tmp_path):
    from gmcpt.regress import check_suite, pytest_cases

    copy = tmp_path / "optional"
    shutil.copytree(suite, copy)
    manifest_path = copy / "golden" / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    manifest["scenes"]["elsewhere"] = {"file": "../absent/scene.xml", "optional": True}
    manifest_path.write_text(json.dumps(manifest))
    [case] = pytest_cases(copy, ["elsewhere"])
    assert "scene file not found" in case.marks[0].kwargs["reason"]
    [result] = check_suite(copy, ["elsewhere"])
    assert result.skipped and not result.passed


@pytest.mark.parametrize("damage, message", [
    ("new scene", "has no golden"),
    ("resolution", "resolution changed"),
    ("broken xml", "malformed scene XML"),
    ("no manifest", "has no golden"),
    ("unknown scene", "no scene nope"),
])
def test_bad_input_exits_2_with_one_line(suite, tmp_path, capsys, damage, message):
    from gmcpt.cli.regress import main

    copy = tmp_path / "bad"
    shutil.copytree(suite, copy)
    args = [copy]
    if damage == "new scene":
        (copy / "extra.xml").write_text(box_scene())
    elif damage == "resolution":
        (copy / "box.xml").write_text(box_scene(size=48))
    elif damage == "broken xml":
        (copy / "table.xml").write_text("<scene version='3.0.0'><shape")
    elif damage == "no manifest":
        (copy / "golden" / "manifest.json").unlink()
    else:
        args += ["--scene", "nope"]
    report = tmp_path / "report.html"
    assert main([*map(str, args), "--report", str(report)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and not report.exists()
    assert captured.err.count("\n") == 1 and captured.err.startswith("error: ") and message in captured.err


def test_update_keeps_goldens_when_a_scene_is_broken(suite, tmp_path, capsys):
    from gmcpt.cli.regress import main

    copy = tmp_path / "broken"
    shutil.copytree(suite, copy)
    before = (copy / "golden" / "manifest.json").read_bytes()
    (copy / "table.xml").write_text("<scene version='3.0.0'><shape")
    assert main([str(copy), "--update"]) == 2
    assert "malformed scene XML" in capsys.readouterr().err
    assert (copy / "golden" / "manifest.json").read_bytes() == before
