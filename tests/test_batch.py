"""``gmcpt batch``: frames named and planned, written once and resumed, the same bits on Ray."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import CORNELL, ROOT, STILL_LIFE

TINY = ("--res", "16", "16", "--spp", "4", "--method", "pawnnm")


def gmcpt(*args, env=None, check=True):
    """``python -m gmcpt ARGS`` in a fresh process; fails the test on a non-zero status if ``check``."""
    environment = dict(os.environ, PYTHONWARNINGS="ignore", **(env or {}))
    result = subprocess.run([sys.executable, "-m", "gmcpt", *map(str, args)], capture_output=True, text=True,
                            cwd=ROOT, env=environment, timeout=600)
    assert not check or result.returncode == 0, result.stderr
    return result


def same_outputs(first, second, names):
    """True if every frame's EXR channels and PNG bytes are equal in both folders."""
    from gmcpt.io.exr import read_exr

    for name in names:
        a, b = read_exr(first / f"{name}.exr"), read_exr(second / f"{name}.exr")
        if a.keys() != b.keys() or not all(np.array_equal(a[k], b[k]) for k in a):
            return False
        if (first / f"{name}.png").read_bytes() != (second / f"{name}.png").read_bytes():
            return False
    return True


def test_frames_are_named_from_scene_and_sweep():
    from gmcpt.cli.batch import frame_name, scene_name, sweep_points
    from gmcpt.errors import GmcptError

    assert scene_name(CORNELL) == "cornell-box" and scene_name("shots/a.xml") == "a"
    assert sweep_points([]) == [()]
    points = sweep_points(["seed=1,2"], "0:2")
    assert points == [(("frame", "0"), ("seed", "1")), (("frame", "0"), ("seed", "2")),
                      (("frame", "1"), ("seed", "1")), (("frame", "1"), ("seed", "2"))]
    assert frame_name("anim", points[1]) == "anim_frame-0000_seed-0002"
    assert frame_name("a b", (("light", "0.5/x"),)) == "a_b_light-0.5_x"
    for sweeps, frames in ((["seed"], None), (["seed=1,,2"], None), (["1x=2"], None), ([], "3:3"), ([], "a:b"),
                           (["frame=1"], "0:2")):
        with pytest.raises(GmcptError):
            sweep_points(sweeps, frames)


@pytest.fixture(scope="module")
def one_process(tmp_path_factory):
    """A batch of two scenes, two frames each, in one process, and proof that it never imported Ray."""
    out = tmp_path_factory.mktemp("batch") / "one"
    code = ("import sys; from gmcpt.cli import main; status = main(sys.argv[1:]); "
            "print('ray imported' if 'ray' in sys.modules else 'no ray'); sys.exit(status)")
    result = subprocess.run([sys.executable, "-c", code, "batch", CORNELL, STILL_LIFE, *TINY, "--sweep", "seed=1,2",
                             "--out", out, "-q"], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr
    return out, result


def test_batch_writes_every_frame_as_the_single_render_does(one_process, tmp_path):
    out, result = one_process
    assert "no ray" in result.stdout and result.stderr == ""  # -q: nothing on stderr
    names = [f"{scene}_seed-000{seed}" for scene in ("cornell-box", "still-life") for seed in (1, 2)]
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["batch-summary.json"] + [f"{n}{suffix}" for n in names for suffix in (".exr", ".json", ".png")])
    summary = json.loads((out / "batch-summary.json").read_text())
    assert [item["name"] for item in summary["items"]] == names and summary["rendered"] == 4
    assert all({"render_s", "completion_s", "total_s"} <= item["timings"].keys() for item in summary["items"])
    # the same render as render_and_complete.py with the same options (and torch threads)
    single = tmp_path / f"{names[1]}.exr"
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run([sys.executable, str(ROOT / "render_and_complete.py"), CORNELL, *TINY, "-D", "seed=2",
                           "--out", single, "-q"], capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    assert same_outputs(out, tmp_path, names[1:2])


def test_batch_resumes_skipping_complete_frames(one_process, tmp_path):
    out, _ = one_process
    copy = tmp_path / "copy"
    copy.mkdir()
    for path in out.iterdir():
        (copy / path.name).write_bytes(path.read_bytes())
    record = json.loads((copy / "cornell-box_seed-0001.json").read_text())
    record["batch"]["key"] = "another request"
    (copy / "cornell-box_seed-0001.json").write_text(json.dumps(record))
    (copy / "cornell-box_seed-0003.exr").write_bytes(b"half a file from another tool")
    summary = json.loads(gmcpt("batch", CORNELL, *TINY, "--sweep", "seed=1,2,3", "--out", copy, "-q").stdout)
    assert (summary["rendered"], summary["skipped"]) == (2, 1)
    statuses = {item["name"]: item["status"] for item in
                json.loads((copy / "batch-summary.json").read_text())["items"]}
    assert statuses == {"cornell-box_seed-0001": "rendered", "cornell-box_seed-0002": "skipped",
                        "cornell-box_seed-0003": "rendered"}
    assert same_outputs(out, copy, ["cornell-box_seed-0001", "cornell-box_seed-0002"])


def test_a_task_run_again_keeps_the_frame_its_first_run_wrote(one_process, tmp_path):
    """A worker lost after writing a frame but before reporting it: the retry finds the frame, writes nothing."""
    import torch

    from gmcpt.cli.batch import build_parser, plan, render_job

    out, _ = one_process
    jobs = plan(build_parser().parse_args([str(CORNELL), *TINY, "--sweep", "seed=1", "--out", str(out)]))
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    threads = torch.get_num_threads()
    try:
        row = render_job(jobs[0])
    finally:
        torch.set_num_threads(threads)
    assert row["status"] == "found" and row["name"] == "cornell-box_seed-0001"
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before


@pytest.mark.slow  # 46 s, most of it Ray starting twice: the cluster path runs in make test-slow
def test_ray_batch_is_bit_identical_and_survives_a_killed_worker(one_process, tmp_path):
    """Two scenes, two frames each, as Ray tasks; the first task kills its own process, Ray runs it again."""
    pytest.importorskip("ray")
    out, _ = one_process
    marker, on_ray = tmp_path / "crashed", tmp_path / "ray"
    result = gmcpt("batch", CORNELL, STILL_LIFE, *TINY, "--sweep", "seed=1,2", "--out", on_ray, "--ray", "local",
                   "-q", env={"GMCPT_TEST_CRASH_ONCE": str(marker)})
    assert marker.is_file()  # a worker died mid-batch
    assert "Token authentication" not in result.stderr  # Ray's notice about its own default is left unsaid
    summary = json.loads((on_ray / "batch-summary.json").read_text())
    assert [item["name"] for item in summary["items"]] == [item["name"] for item in json.loads(
        (out / "batch-summary.json").read_text())["items"]]
    assert summary["ray"] == "local" and json.loads(result.stdout)["rendered"] == 4
    # every frame written once, whole: the same files as the one-process run, no temporaries left over
    assert sorted(p.name for p in on_ray.iterdir()) == sorted(p.name for p in out.iterdir())
    assert same_outputs(out, on_ray, [item["name"] for item in summary["items"]])


def test_frames_of_the_shipped_scenes_move_and_frame_0_is_the_still(tmp_path):
    """Frame N turns the Cornell box's camera and the still life's spot light N degrees; frame 0 is today's image."""
    from gmcpt.io.exr import read_exr

    gmcpt("batch", CORNELL, STILL_LIFE, *TINY, "--frames", "0:3", "--out", tmp_path / "anim", "-q")
    gmcpt("batch", CORNELL, STILL_LIFE, *TINY, "--out", tmp_path / "still", "-q")
    for scene, moved in (("cornell-box", "albedo.R"), ("still-life", "sparse.R")):
        frames = [read_exr(tmp_path / "anim" / f"{scene}_frame-000{n}.exr") for n in range(3)]
        assert not np.array_equal(frames[0][moved], frames[1][moved])
        assert not np.array_equal(frames[1][moved], frames[2][moved])
        still = read_exr(tmp_path / "still" / f"{scene}.exr")
        assert all(np.array_equal(still[name], frames[0][name]) for name in still)


@pytest.mark.slow
def test_ray_batch_of_two_scenes_matches_one_process_at_16_spp(tmp_path):
    pytest.importorskip("ray")
    options = ("--res", "64", "48", "--spp", "16", "--sweep", "seed=0,1")
    gmcpt("batch", CORNELL, STILL_LIFE, *options, "--out", tmp_path / "one", "-q")
    gmcpt("batch", CORNELL, STILL_LIFE, *options, "--out", tmp_path / "ray", "--ray", "local", "-q")
    names = [f"{scene}_seed-000{seed}" for scene in ("cornell-box", "still-life") for seed in (0, 1)]
    assert same_outputs(tmp_path / "one", tmp_path / "ray", names)


BAD = {"missing scene": (["nope.xml"], "scene file not found"),
       "bad frames": ([CORNELL, "--frames", "5:2"], "--frames expects START:STOP"),
       "bad sweep": ([CORNELL, "--sweep", "seed"], "--sweep expects NAME=V1,V2"),
       "bad ray address": ([CORNELL, "--ray", "somewhere"], "--ray expects local, auto"),
       "no ray cluster there": ([CORNELL, "--ray", "127.0.0.1:1"], "cannot reach the Ray cluster at 127.0.0.1:1"),
       "bad threads": ([CORNELL, "--threads", "0"], "--threads must be >= 1"),
       "same name twice": ([CORNELL, CORNELL], "both write cornell-box.exr"),
       "bad rate": ([CORNELL, "--rate", "2"], "rate must be in (0, 1]")}


@pytest.mark.parametrize("case", sorted(BAD))
def test_batch_bad_input_is_one_line_and_writes_nothing(case, tmp_path, capsys, monkeypatch):
    from gmcpt.cli import main

    monkeypatch.chdir(tmp_path)
    arguments, message = BAD[case]
    assert main(["batch", *map(str, arguments), "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: ") and error.count("\n") == 1 and message in error, error
    assert list(tmp_path.iterdir()) == []
