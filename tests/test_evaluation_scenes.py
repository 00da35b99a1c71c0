"""Scene edits for evaluation (load_scene(without=...)) and the evaluation scene list."""
import pytest

CORNELL = "scenes/cornell-box/scene.xml"


def test_without_leaves_out_the_named_shapes(mi):
    from gmcpt.render.scene import load_scene

    full = load_scene(CORNELL, (16, 16))
    reduced = load_scene(CORNELL, (16, 16), without=("floor", "ceiling"))
    # Mitsuba merges shapes that share a BSDF, so count primitives, not shapes
    def primitives(scene):
        return sum(shape.primitive_count() for shape in scene.shapes())
    assert 0 < primitives(reduced) < primitives(full)


def test_without_unknown_id_is_a_one_line_error(mi):
    from gmcpt.errors import GmcptError
    from gmcpt.render.scene import load_scene

    with pytest.raises(GmcptError, match="no top-level element with id nonexistent"):
        load_scene(CORNELL, (16, 16), without=("nonexistent",))


def test_reference_key_tells_variants_apart():
    from gmcpt.evaluation.reference import reference_key

    plain = reference_key(CORNELL, 64, 256, 1)
    assert reference_key(CORNELL, 64, 256, 1, without=()) == plain
    assert reference_key(CORNELL, 64, 256, 1, without=("floor",)) != plain


def test_by_name():
    from gmcpt.evaluation.scenes import BREAKFAST_OPEN, QUALITY_SCENES, by_name

    assert by_name(None) == list(QUALITY_SCENES)
    assert by_name(["breakfast-room-open"]) == [BREAKFAST_OPEN]
    with pytest.raises(ValueError, match="unknown scene"):
        by_name(["kitchen"])


def test_reference_key_tells_sizes_apart():
    from gmcpt.evaluation.reference import reference_key

    assert reference_key(CORNELL, 64, 256, 1) != reference_key(CORNELL, (64, 48), 256, 1)
    assert "-64x48px-" in reference_key(CORNELL, (64, 48), 256, 1)


def test_a_missing_imported_scene_is_skipped_with_one_line(tmp_path):
    """Without data/real-scenes (a fresh clone), the real interiors are left out, each said in one line."""
    import os
    import subprocess
    import sys

    code = ("from gmcpt.evaluation.scenes import evaluation_scenes\n"
            "print([s.name for s in evaluation_scenes(['dining-room', 'cornell-box'], 1, print)])")
    env = dict(os.environ, GMCPT_REAL_SCENES=str(tmp_path / "nothing"))
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.strip().splitlines()
    assert lines == [f"skipping dining-room: {tmp_path / 'nothing' / 'dining-room' / 'scene.xml'} not found "
                     "(python scripts/import_scenes.py imports it)", "['cornell-box', 'proc-2000000']"]


def test_the_real_scenes_are_marked_real():
    from gmcpt.evaluation.scenes import BREAKFAST_OPEN, CORNELL as CORNELL_SCENE, IMPORTED, procedural_scenes

    assert BREAKFAST_OPEN.real and all(scene.real for scene in IMPORTED) and len(IMPORTED) >= 4
    assert not CORNELL_SCENE.real and not procedural_scenes(1)[0].real


def test_a_stopped_reference_resumes_after_its_last_pass_to_the_same_image(mi, tmp_path):
    """A reference render stopped in its third pass keeps two passes' sum; the next render starts at the third and
    ends with the image of a render run through, and the checkpoint is gone once the reference is written. A
    damaged checkpoint is rendered over from the first pass."""
    import numpy as np

    from gmcpt.evaluation.reference import render_reference

    class Stopped(Exception):
        pass

    def stop_in_pass_3(message):
        if "pass 3/" in message:
            raise Stopped

    def render(folder, progress=None):
        return render_reference(CORNELL, (16, 12), 8, seed=5, pass_spp=2, progress=progress, folder=folder)

    whole = render(tmp_path / "whole")
    with pytest.raises(Stopped):
        render(tmp_path / "stopped", stop_in_pass_3)
    checkpoint, = (tmp_path / "stopped").glob("*.partial.npz")
    messages = []
    assert np.array_equal(render(tmp_path / "stopped", messages.append), whole)
    assert sum("kept from an interrupted render" in m for m in messages) == 2 and len(messages) == 4
    assert not checkpoint.exists() and len(list((tmp_path / "stopped").glob("*.exr"))) == 1
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    (damaged / checkpoint.name).write_bytes(b"not a numpy file")
    messages.clear()
    assert np.array_equal(render(damaged, messages.append), whole)
    assert not any("kept" in m for m in messages)
