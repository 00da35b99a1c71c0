"""``gmcpt batch --frames A:B --history N``: a sequence written frame by frame, resumed to the same images."""
import json

import numpy as np

import pytest

from conftest import CORNELL
from test_batch import gmcpt, same_outputs

SEQUENCE = ("--res", "32", "24", "--budget", "2", "--history", "4", "-q")


def test_a_stopped_sequence_resumes_with_the_images_of_an_uninterrupted_run(tmp_path):
    straight, stopped = tmp_path / "straight", tmp_path / "stopped"
    gmcpt("batch", CORNELL, "--frames", "0:4", *SEQUENCE, "--out", straight)
    names = [f"cornell-box_frame-000{frame}" for frame in range(4)]
    record = json.loads((straight / f"{names[2]}.json").read_text())
    assert record["parameters"]["sequence"] and record["history_frames"] == 2 and record["history_pixels"] > 0.5
    assert {"features_s", "render_s", "denoise_s"} <= record["timings"].keys() and "versions" in record
    gmcpt("batch", CORNELL, "--frames", "0:2", *SEQUENCE, "--out", stopped)  # stopped after frame 1
    summary = json.loads(gmcpt("batch", CORNELL, "--frames", "0:4", *SEQUENCE, "--out", stopped).stdout)
    assert (summary["rendered"], summary["skipped"]) == (2, 2)
    assert same_outputs(straight, stopped, names)
    state = stopped / ".sequence-state"  # a file a past frame, written once, and the rest
    assert sorted(path.name for path in state.iterdir()) == [f"frame-00000{frame}.npz" for frame in range(4)] + ["rest.npz"]
    written = (state / "frame-000002.npz").stat().st_mtime_ns
    gmcpt("batch", CORNELL, "--frames", "0:6", *SEQUENCE, "--out", stopped)
    assert sorted(path.name for path in state.iterdir()) == [f"frame-00000{frame}.npz" for frame in range(2, 6)] + [
        "rest.npz"]  # frames 0 and 1 left the history of 4
    assert (state / "frame-000002.npz").stat().st_mtime_ns == written
    (stopped / ".sequence-state" / "rest.npz").write_bytes(b"not a state")
    broken = gmcpt("batch", CORNELL, "--frames", "0:7", *SEQUENCE, "--out", stopped, check=False)
    assert broken.returncode == 2 and broken.stderr.strip().count("\n") == 0
    assert "sequence-state" in broken.stderr and "delete it" in broken.stderr


def test_an_animation_written_one_file_a_frame_is_the_frames_sequence(tmp_path):
    """The Cornell box's frames 0-3 written as four scene files (its $frame replaced) and given in order with
    --history: the images of its --frames sequence, to the bit (each file's elements compared with the held one's,
    the camera's and the sphere's change set)."""
    from gmcpt.io.exr import read_rgb_exr

    files = []
    for frame in range(4):
        files.append(tmp_path / f"shot-{frame}.xml")
        files[-1].write_text(CORNELL.read_text().replace("$frame", str(frame)))
    assert SEQUENCE[-1] == "-q"
    log = gmcpt("batch", *files, *SEQUENCE[:-1], "--out", tmp_path / "files").stderr
    assert "frame 3: 2 samples a pixel, 3 past frames\n" in log and "loaded whole" not in log and "warning" not in log
    gmcpt("batch", CORNELL, "--frames", "0:4", *SEQUENCE, "--out", tmp_path / "frames")
    for frame in range(4):
        record = json.loads((tmp_path / "files" / f"shot-{frame}.json").read_text())
        assert record["parameters"]["sequence"] and record["history_frames"] == min(frame, 4)
        np.testing.assert_array_equal(read_rgb_exr(tmp_path / "files" / f"shot-{frame}.exr"),
                                      read_rgb_exr(tmp_path / "frames" / f"cornell-box_frame-000{frame}.exr"))


def test_files_whose_numbers_a_shell_misorders_are_named():
    from gmcpt.cli.sequence_batch import out_of_order

    assert out_of_order(["s/shot-1.xml", "s/shot-10.xml", "s/shot-2.xml"]) == ("s/shot-10.xml", "s/shot-2.xml")
    assert out_of_order(["shot-9.xml", "shot-10.xml"]) is None
    assert out_of_order(["b.xml", "a.xml"]) == ("b.xml", "a.xml")


@pytest.mark.parametrize("options, message", [
    ((), "give --frames A:B, or the animation's scene files"), (("--frames", "0:2", "--rate", "0.3"), "drop --rate"),
    (("--frames", "0:2", "--chunk", "3"), "give --ray"), (("--frames", "0:2", "--sweep", "seed=1,2"), "no --sweep"),
    ((CORNELL, "--frames", "0:2"), "not both")])
def test_a_sequence_the_options_cannot_make_gets_one_line(tmp_path, options, message):
    result = gmcpt("batch", CORNELL, *options, *SEQUENCE, "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert not (tmp_path / "out").exists()


def test_a_frame_that_fails_is_one_line_naming_it(tmp_path):
    scene = tmp_path / "flat.xml"
    scene.write_text(CORNELL.read_text().replace('<sensor type="perspective" id="camera">', '<sensor type="orthographic">')
                     .replace('<float name="fov" value="39.3"/>', "").replace('<string name="fov_axis" value="x"/>', ""))
    result = gmcpt("batch", scene, "--frames", "0:2", *SEQUENCE, "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0, result.stderr
    assert "frame 0 (flat_frame-0000)" in result.stderr and "pinhole" in result.stderr


def test_a_scene_without_an_integrator_is_a_sequence_until_a_frames_mesh_is_missing(tmp_path):
    """A scene without an <integrator> traces with the default path (once an internal error); a frame whose mesh
    file is missing is one line naming it, after the frames before it."""
    from conftest import write_blob

    for frame in (0, 1):
        write_blob(tmp_path / f"blob{frame}.obj", side=12)
    (tmp_path / "anim.xml").write_text("""<scene version="3.0.0"><default name="frame" value="0"/>
        <sensor type="perspective"><transform name="to_world"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/>
        </transform></sensor><emitter type="constant"/>
        <shape type="obj"><string name="filename" value="blob$frame.obj"/></shape></scene>""")
    result = gmcpt("batch", tmp_path / "anim.xml", "--frames", "0:3", *SEQUENCE, "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0, result.stderr
    assert "frame 2 (anim_frame-0002)" in result.stderr and "blob2.obj" in result.stderr
    written = sorted(path.name for path in (tmp_path / "out").glob("*.exr"))
    assert written == ["anim_frame-0000.exr", "anim_frame-0001.exr"]


def test_frames_of_one_scene_are_a_sequence_unless_history_is_0(tmp_path):
    gmcpt("batch", CORNELL, "--frames", "0:2", "--res", "16", "16", "--budget", "1", "-q", "--out", tmp_path / "seq")
    record = json.loads((tmp_path / "seq" / "cornell-box_frame-0001.json").read_text())
    assert record["parameters"]["sequence"] and record["parameters"]["history"] == 8 and record["history_frames"] == 1
    gmcpt("batch", CORNELL, "--frames", "0:2", "--res", "16", "16", "--budget", "1", "--history", "0", "-q",
          "--out", tmp_path / "alone")
    record = json.loads((tmp_path / "alone" / "cornell-box_frame-0001.json").read_text())
    assert "sequence" not in record["parameters"] and "budget_choice" in record
    result = gmcpt("batch", CORNELL, "--frames", "0:2", "--res", "16", "16", "--rate", "0.5", "--out", tmp_path / "rate")
    assert "independent frames: --rate is for single frames" in result.stderr


def test_a_timed_sequence_records_its_time_and_each_frame_its_budget(tmp_path):
    gmcpt("batch", CORNELL, "--frames", "0:3", "--res", "16", "16", "--time", "0.3", "-q", "--out", tmp_path / "t")
    records = [json.loads((tmp_path / "t" / f"cornell-box_frame-000{frame}.json").read_text()) for frame in range(3)]
    assert all(record["parameters"]["time"] == 0.3 for record in records)
    assert records[0]["budget"] == records[0]["parameters"]["budget"] != records[2]["budget"]


@pytest.mark.parametrize("change, options, message", [
    (None, ("--frames", "0:2", "--sweep", "seed=0,1", "--history", "2"), "no --sweep"),
    (None, ("--frames", "0:2", "--history", "0", "--chunk", "2", "--ray", "local"), "independent frames are a task"),
    ('<rotate y="1" angle="$frame"/>', ("--frames", "0:2"), "nothing in it reads $frame")])
def test_frames_the_scene_or_options_cannot_animate_get_one_line(tmp_path, change, options, message):
    scene = CORNELL
    if change:
        scene = tmp_path / "still.xml"
        scene.write_text(CORNELL.read_text().replace(change, "").replace('<default name="frame" value="0"/>', ""))
    result = gmcpt("batch", scene, *options, "--res", "16", "16", "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert not (tmp_path / "out").exists()


def test_a_sequence_state_of_other_settings_is_one_line(tmp_path):
    gmcpt("batch", CORNELL, "--frames", "0:1", "--res", "16", "16", "--budget", "1", "-q", "--out", tmp_path / "s")
    result = gmcpt("batch", CORNELL, "--frames", "0:2", "--res", "16", "16", "--budget", "2", "-q",
                   "--out", tmp_path / "s", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0
    assert "other settings" in result.stderr and "delete it" in result.stderr
