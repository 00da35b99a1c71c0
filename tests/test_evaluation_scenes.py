"""Scene edits for evaluation (load_scene(without=...)) and the evaluation scene list."""
import pytest

CORNELL = "scenes/cornell-box/scene.xml"


def test_without_leaves_out_the_named_shapes(mi):
    from gmcpt.scene import load_scene

    full = load_scene(CORNELL, (16, 16))
    reduced = load_scene(CORNELL, (16, 16), without=("floor", "ceiling"))
    # Mitsuba merges shapes that share a BSDF, so count primitives, not shapes
    def primitives(scene):
        return sum(shape.primitive_count() for shape in scene.shapes())
    assert 0 < primitives(reduced) < primitives(full)


def test_without_unknown_id_is_a_one_line_error(mi):
    from gmcpt.errors import GmcptError
    from gmcpt.scene import load_scene

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
