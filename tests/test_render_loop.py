"""``masked_path`` with ``history``: successive ``mi.render`` calls are the frames of one sequence."""
import json

import numpy as np
import pytest

from conftest import CORNELL
from test_batch import gmcpt

RES = 32


def cornell_at(mi, scene, params, frame: int) -> None:
    """The Cornell box at ``frame`` of its ``$frame`` animation, moved by hand through ``mi.traverse``: the camera and
    the blue sphere turned ``frame`` degrees about the vertical, in the XML loader's precision."""
    import drjit as dr

    whole, single = mi.ScalarTransform4d, mi.ScalarTransform4f
    turn = whole().rotate([0, 1, 0], frame)
    params["camera.to_world"] = single(mi.ScalarMatrix4f(
        (turn @ whole().look_at(origin=[0, 0, 3.9], target=[0, 0, 0], up=[0, 1, 0])).matrix))
    params["plastic_sphere.to_world"] = (single(mi.ScalarMatrix4f(turn.matrix)) @ single().translate([-0.45, -0.84, 0.45])
                                         @ single().scale(0.16))
    dr.make_opaque(params["camera.to_world"], params["plastic_sphere.to_world"])
    params.update()


@pytest.fixture
def loop(mi):
    scene = mi.load_file(str(CORNELL), res=RES)
    integrator = mi.load_dict({"type": "masked_path", "history": 8, "budget": 2})
    return scene, integrator, mi.traverse(scene)


@pytest.mark.parametrize("moved", ["by hand", "by SceneFrames"])
def test_the_frames_of_a_render_loop_equal_the_batch_sequence(mi, loop, tmp_path, moved):
    """The README's loop (its scene file's frames held by SceneFrames) and one that moves the scene by hand."""
    from gmcpt.io.exr import read_rgb_exr
    from gmcpt.render.frames import SceneFrames

    scene, integrator, params = loop
    held = SceneFrames(CORNELL, (RES, RES))
    frames = []
    for frame in range(4):
        if moved == "by hand":
            cornell_at(mi, scene, params, frame)
        else:
            scene = held.at({"frame": str(frame)})
        image = np.asarray(mi.render(scene, integrator=integrator))
        frames.append((image, integrator.last_frame.info.sequence))
    assert image.shape == (RES, RES, 17) and frames[3][1].history_frames == 3 and frames[3][1].history_pixels > 0.5
    bitmap = scene.sensors()[0].film().bitmap()  # the film holds the frame's layers, named
    assert bitmap.channel_count() == 17 and "albedo.R" in [bitmap.struct_()[i].name for i in range(17)]

    gmcpt("batch", CORNELL, "--frames", "0:4", "--res", str(RES), str(RES), "--budget", "2", "-q",
          "--out", tmp_path / "seq")
    for frame, (image, info) in enumerate(frames):
        name = tmp_path / "seq" / f"cornell-box_frame-{frame:04d}"
        record = json.loads(name.with_suffix(".json").read_text())
        for key in ("history_frames", "path_samples", "history_pixels", "history_samples", "seed"):
            assert record.get(key, record["parameters"].get(key)) == getattr(info, key), (frame, key)
        assert record["dropped"] == info.dropped.to_json(), frame
        written = read_rgb_exr(name.with_suffix(".exr"))
        if moved == "by SceneFrames":  # the batch's own way to its frames
            np.testing.assert_array_equal(written, image[..., :3])
        else:  # the same samples and decisions; a hand-moved camera rounds differently in the last bits
            assert np.abs(written - image[..., :3]).max() <= 1e-4 * max(1.0, float(written.max())), frame


def test_reset_another_size_or_another_scene_starts_a_new_sequence(mi, loop):
    scene, integrator, params = loop
    first = np.asarray(mi.render(scene, integrator=integrator))
    mi.render(scene, integrator=integrator)
    assert integrator.last_frame.info.sequence.history_frames == 1
    integrator.reset()
    again = np.asarray(mi.render(scene, integrator=integrator))
    assert integrator.last_frame.info.sequence.history_frames == 0 and np.array_equal(first, again)
    params["camera.film.size"] = [RES // 2, RES // 2]
    params.update()
    assert np.asarray(mi.render(scene, integrator=integrator)).shape == (RES // 2, RES // 2, 17)
    assert integrator.last_frame.info.sequence.history_frames == 0
    other = mi.load_file(str(CORNELL), res=RES // 2)
    mi.render(other, integrator=integrator)
    assert integrator.last_frame.info.sequence.history_frames == 0
    mi.render(other, integrator=integrator, seed=5)  # a seed given is the frame's number
    record = integrator.last_frame.info.sequence
    assert record.frame == 5 and record.history_frames == 1


@pytest.mark.parametrize("properties, message", [({"rate": 0.3}, "drop rate"), ({"mask": "random"}, "drop mask"),
                                                 ({"history": 65}, "history must be"), ({"time": -1}, "time")])
def test_a_history_the_plugin_cannot_make_is_one_line(mi, properties, message):
    from gmcpt.errors import GmcptError
    from gmcpt.runtime.plugins import plugin_errors

    with pytest.raises(GmcptError, match=message) as caught, plugin_errors():
        mi.load_dict({"type": "masked_path", "history": 8, **properties})
    assert "\n" not in str(caught.value)


def test_an_spp_to_mi_render_with_history_is_one_line(mi, loop):
    from gmcpt.errors import GmcptError

    scene, integrator, _ = loop
    with pytest.raises(GmcptError, match="not an spp"):  # what mi.render(scene, spp=4) calls, unwrapped
        integrator.render(scene, spp=4)
