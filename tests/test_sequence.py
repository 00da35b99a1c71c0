"""Sequences (gmcpt.sequence): reuse on a still camera, no smear after a cut or a changed light, resuming, seeds."""
import numpy as np
import pytest

from conftest import CORNELL, STILL_LIFE

SIZE = (48, 40)


def _scene(path=CORNELL, frame=0):
    from gmcpt.scene import load_scene
    return load_scene(path, resolution=SIZE, parameters={"frame": str(frame)})


def _renderer(**settings):
    from gmcpt.sequence import SequenceRenderer, SequenceSettings
    return SequenceRenderer(SequenceSettings(**{"budget": 2, "seed": 5, **settings}))


def test_a_still_camera_reuses_the_earlier_frames_and_keeps_the_budget(mi):
    scene = _scene()
    renderer = _renderer()
    infos = [renderer.render(scene, index)[1] for index in range(3)]
    pixels = SIZE[0] * SIZE[1]
    assert [info["path_samples"] for info in infos] == [2 * pixels] * 3
    assert infos[0]["history_pixels"] == 0 and infos[0]["history_frames"] == 0
    assert infos[1]["history_pixels"] > 0.8 and infos[2]["history_samples"] > infos[1]["history_samples"]
    assert infos[0]["carried_pixels"] == 0 and infos[1]["carried_pixels"] > 0.8  # the frame shown before, carried


def test_same_seed_same_frames_and_a_resumed_sequence_gives_the_same_images(mi, tmp_path):
    from gmcpt.sequence import SequenceRenderer, SequenceSettings

    frames = [_scene(frame=index) for index in range(3)]  # the cornell box turns a degree a frame
    straight = _renderer()
    images = [straight.render(scene, index)[0] for index, scene in enumerate(frames)]
    first = _renderer()
    for index in range(2):
        first.render(frames[index], index)
    np.savez(tmp_path / "state.npz", **first.state())
    resumed = _renderer()
    resumed.restore(dict(np.load(tmp_path / "state.npz")))
    np.testing.assert_array_equal(resumed.render(frames[2], 2)[0], images[2])
    with pytest.raises(Exception, match="other settings"):
        SequenceRenderer(SequenceSettings(budget=4, seed=5)).restore(dict(np.load(tmp_path / "state.npz")))


def test_after_a_cut_the_frame_is_the_single_frame_render(mi):
    renderer = _renderer()
    renderer.render(_scene(CORNELL), 0)
    image, info, _ = renderer.render(_scene(STILL_LIFE), 1)
    assert info["history_pixels"] < 0.01 and info["carried_pixels"] < 0.01
    alone, _, _ = _renderer(history=0).render(_scene(STILL_LIFE), 1)
    if info["history_pixels"] == 0:
        np.testing.assert_array_equal(image, alone)
    else:  # a stray pixel on the same spot of both scenes
        assert np.mean(np.abs(image - alone)) < 1e-3


def test_a_changed_light_drops_the_history_that_disagrees(mi):
    scene = _scene()
    renderer = _renderer()
    renderer.render(scene, 0)
    parameters = mi.traverse(scene)
    key = next(k for k in parameters.keys() if k.endswith("radiance.value") and "light" in k)
    parameters[key] = parameters[key] * 8
    parameters.update()
    _, info, _ = renderer.render(scene, 1)
    assert info["history_dropped"] > 0.5 * (info["history_dropped"] + info["history_pixels"])


@pytest.mark.parametrize("settings, message", [({"history": -1}, "history"), ({"history": 2.5}, "history"),
                                               ({"decay": 0.0}, "decay"), ({"budget": 0}, "budget")])
def test_bad_settings_get_one_line(settings, message):
    from gmcpt.errors import GmcptError
    from gmcpt.sequence import SequenceSettings

    with pytest.raises(GmcptError, match=message):
        SequenceSettings(**settings)
