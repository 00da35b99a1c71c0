"""``gmcpt batch --frames A:B --history N``: a sequence written frame by frame, resumed to the same images."""
import json

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
    (stopped / ".sequence-state.npz").write_bytes(b"not a state")
    broken = gmcpt("batch", CORNELL, "--frames", "0:5", *SEQUENCE, "--out", stopped, check=False)
    assert broken.returncode == 2 and broken.stderr.strip().count("\n") == 0
    assert "sequence-state" in broken.stderr and "delete it" in broken.stderr


@pytest.mark.parametrize("options, message", [((), "give --frames"), (("--frames", "0:2", "--rate", "0.3"), "drop --rate"),
                                              (("--frames", "0:2", "--chunk", "3"), "give --ray")])
def test_a_sequence_the_options_cannot_make_gets_one_line(tmp_path, options, message):
    result = gmcpt("batch", CORNELL, *options, *SEQUENCE, "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert not (tmp_path / "out").exists()


def test_a_frame_that_fails_is_one_line_naming_it(tmp_path):
    scene = tmp_path / "flat.xml"
    scene.write_text(CORNELL.read_text().replace('<sensor type="perspective">', '<sensor type="orthographic">')
                     .replace('<float name="fov" value="39.3"/>', "").replace('<string name="fov_axis" value="x"/>', ""))
    result = gmcpt("batch", scene, "--frames", "0:2", *SEQUENCE, "--out", tmp_path / "out", check=False)
    assert result.returncode == 2 and result.stderr.strip().count("\n") == 0, result.stderr
    assert "frame 0 (flat_frame-0000)" in result.stderr and "pinhole" in result.stderr
