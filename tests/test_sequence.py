"""Sequences (gmcpt.temporal.sequence): reuse on a still camera, no smear after a cut or a changed light, resuming,
seeds."""
from dataclasses import replace

import numpy as np
import pytest

from conftest import CORNELL, STILL_LIFE

SIZE = (48, 40)


def _scene(path=CORNELL, frame=0):
    from gmcpt.render.scene import load_scene
    return load_scene(path, resolution=SIZE, parameters={"frame": str(frame)})


def _renderer(**settings):
    from gmcpt.temporal.sequence import SequenceRenderer, SequenceSettings
    return SequenceRenderer(SequenceSettings(**{"budget": 2, "seed": 5, **settings}))


def test_a_still_camera_reuses_the_earlier_frames_and_keeps_the_budget(mi):
    scene = _scene()
    renderer = _renderer()
    infos = [renderer.render(scene, index)[1] for index in range(3)]
    pixels = SIZE[0] * SIZE[1]
    assert [info.path_samples for info in infos] == [2 * pixels] * 3
    assert infos[0].history_pixels == 0 and infos[0].history_frames == 0
    assert infos[1].history_pixels > 0.8 and infos[2].history_samples > infos[1].history_samples
    assert infos[0].carried_pixels == 0 and infos[1].carried_pixels > 0.8  # the frame shown before, carried


def test_the_frame_shown_before_weighs_less_where_much_of_the_light_changed():
    from gmcpt.temporal.sequence import CARRY_LIGHT_POWER, SHOWN_CARRY

    renderer = _renderer()
    renderer.shown = (0, np.ones((2, 2, 3), np.float32))
    film = np.full((4, 2), 1.0, np.float32)  # every pixel reads the middle of the shown frame: 1
    shown = [renderer._carried(np.zeros((2, 2, 3), np.float32), film, np.ones(4, bool), 2.0, changed)[0]
             for changed in (0.0, 0.5)]
    assert np.allclose(shown[0], SHOWN_CARRY) and np.allclose(shown[1], SHOWN_CARRY * 0.5 ** CARRY_LIGHT_POWER)
    assert CARRY_LIGHT_POWER > 0


def test_a_pixel_whose_own_light_held_keeps_its_carry_where_much_of_the_light_changed():
    """Where the probes saw a pixel's light hold, the frame-wide share of changed light does not take its carry; where
    they saw it change, the frame-wide share still sets it."""
    from gmcpt.temporal.sequence import CARRY_HELD_POWER, CARRY_LIGHT_POWER, SHOWN_CARRY

    renderer = _renderer()
    renderer.shown = (0, np.ones((2, 2, 3), np.float32))
    film = np.full((4, 2), 1.0, np.float32)
    held = np.array([1.0, 0.0, 0.9, 0.5], np.float32)
    shown = renderer._carried(np.zeros((2, 2, 3), np.float32), film, np.ones(4, bool), 2.0, 0.5, held)[0]
    expected = SHOWN_CARRY * np.maximum(0.5 ** CARRY_LIGHT_POWER, held ** CARRY_HELD_POWER)
    np.testing.assert_allclose(shown.reshape(4, 3)[:, 0], expected, rtol=1e-6)
    assert expected[0] == SHOWN_CARRY and expected[1] == SHOWN_CARRY * 0.5 ** CARRY_LIGHT_POWER


@pytest.mark.parametrize("lights", [1, 2, 4])
def test_each_light_gets_signature_samples_apart_in_both_coordinates(mi, lights):
    """Mitsuba picks the light by the sample's first coordinate and hands the light that coordinate stretched: a
    light whose points shared one (the 2x2 grid gave two lights a line each) saw a penumbra move unseen."""
    from gmcpt.temporal.survey import signature_light_sample

    points = signature_light_sample(mi.UInt32(list(range(8))))
    x, y = np.array(points.x, np.float64), np.array(points.y, np.float64)
    assert np.array_equal(x[:4], x[4:]) and np.array_equal(y[:4], y[4:])  # four points, in turn
    light = np.floor(x[:4] * lights)
    stretched = x[:4] * lights - light
    for chosen in np.unique(light):
        mine = light == chosen
        assert mine.sum() == 4 // lights
        assert np.unique(stretched[mine]).size == mine.sum() and np.unique(y[:4][mine]).size == mine.sum()


def test_same_seed_same_frames_and_a_resumed_sequence_gives_the_same_images(mi, tmp_path):
    from gmcpt.temporal.sequence import SequenceRenderer, SequenceSettings

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


def test_a_resumed_still_camera_replays_the_probe_it_saved(mi, tmp_path):
    scene = _scene()
    straight = _renderer()
    images = [straight.render(scene, index)[0] for index in range(3)]
    first = _renderer()
    for index in range(2):
        first.render(scene, index)
    assert first.probe is not None and first.probe.index == 1
    np.savez(tmp_path / "state.npz", **first.state())
    resumed = _renderer()
    resumed.restore(dict(np.load(tmp_path / "state.npz")))
    # frame 2 traces frame 1's probe again (a lost probe would give another placement, another image)
    np.testing.assert_array_equal(resumed.render(scene, 2)[0], images[2])


def test_after_a_cut_the_frame_is_the_single_frame_render(mi):
    renderer = _renderer()
    renderer.render(_scene(CORNELL), 0)
    image, info, _ = renderer.render(_scene(STILL_LIFE), 1)
    assert info.history_pixels < 0.01 and info.carried_pixels < 0.01
    alone, _, _ = _renderer(history=0).render(_scene(STILL_LIFE), 1)
    if info.history_pixels == 0:
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
    assert info.history_dropped > 0.5 * (info.history_dropped + info.history_pixels)


@pytest.mark.parametrize("settings, message", [({"history": -1}, "history"), ({"history": 2.5}, "history"),
                                               ({"decay": 0.0}, "decay"), ({"budget": 0}, "budget")])
def test_bad_settings_get_one_line(settings, message):
    from gmcpt.errors import GmcptError
    from gmcpt.temporal.sequence import SequenceSettings

    with pytest.raises(GmcptError, match=message):
        SequenceSettings(**settings)


def _move(mi, parameters, key, base, offset):
    """Shape ``key``'s vertices at ``base`` + ``offset``, made opaque (no kernel compiled for the move)."""
    import drjit as dr

    parameters[key] = mi.Float((base + np.asarray(offset, np.float32)).ravel())
    dr.make_opaque(parameters[key])
    parameters.update()


def _moving_block(mi, renderer, scene, indices, step: float = -0.1) -> list:
    """Frames ``indices`` of ``scene`` (the Cornell box) rendered by ``renderer``, its short block moved ``step`` along
    x a frame from where the scene has it; their images."""
    parameters, key = mi.traverse(scene), "short_block.vertex_positions"
    base = np.array(parameters[key]).reshape(-1, 3)
    images = []
    for index in indices:
        _move(mi, parameters, key, base, [step * index, 0.0, 0.0])
        images.append(renderer.render(scene, index)[0])
    return images


def test_a_moving_shapes_old_shadow_is_gone_within_one_frame(mi):
    from gmcpt.render.kernels import render_native
    from gmcpt.render.scene import path_integrator
    from gmcpt.temporal.survey import survey

    scene = _scene()
    sensor, integrator = scene.sensors()[0], path_integrator(scene)
    parameters, key = mi.traverse(scene), "short_block.vertex_positions"
    base = np.array(parameters[key]).reshape(-1, 3)
    before = survey(scene, sensor).lighting
    renderer = _renderer()
    for index in range(4):  # history builds up with the block in place
        renderer.render(scene, index, integrator)
    _move(mi, parameters, key, base, [-0.35, 0.0, 0.0])
    after = survey(scene, sensor).lighting
    old_shadow = (after > 4 * before + 0.05 * after.mean()) & (before < 0.1 * after.mean())  # lit now, dark before
    assert old_shadow.mean() > 0.01
    image, info, _ = renderer.render(scene, 4, integrator)
    reference = sum(render_native(scene, sensor, integrator, 64, 900 + i) for i in range(4)) / 4
    luminance = image.reshape(-1, 3).mean(axis=1)
    assert info.dropped.lighting > 0.25 * old_shadow.mean()
    # the old shadow's pixels are as bright as they are now, not darkened by the history of the shadow: against the
    # reference as the whole frame is (OIDN at 2 samples a pixel leaves the frame 4-6% darker, and the old shadow's
    # 70 pixels read 0.89-1.03 of the reference with no history at all, over seeds)
    level = luminance.mean() / reference.mean()
    assert luminance[old_shadow].mean() > 0.9 * level * reference.mean(axis=1)[old_shadow].mean()


def test_a_moving_shape_takes_its_history_from_where_it_was(mi, monkeypatch):
    """The block moves 6-7 pixels a frame: its pixels find their surface where the block was on the past frames
    (:mod:`gmcpt.temporal.motion`), where without it many of them have no history of it."""
    from gmcpt.render.scene import load_scene
    from gmcpt.temporal import sequence

    gather, counts = sequence.gather_history, []

    def spied(*arguments):
        gathered = gather(*arguments)
        counts.append(gathered.summed[:, 3])
        return gathered

    monkeypatch.setattr(sequence, "gather_history", spied)

    def kept() -> float:
        """The share of the block's pixels with history on the last frame."""
        scene = load_scene(CORNELL, resolution=(96, 80))
        renderer = _renderer()
        _moving_block(mi, renderer, scene, range(4), -0.15)
        registry = sequence.survey(scene, scene.sensors()[0]).shapes
        block = [place for place, shape in enumerate(scene.shapes()) if shape.id() == "short_block"][0]
        on_block = sequence._moved_lanes(scene, registry, {block: np.eye(4)})[block]
        return float((counts[-1][on_block] > 0).mean())

    tracked = kept()
    monkeypatch.setattr(sequence.ShapePoses, "update", lambda self, scene: {})
    untracked = kept()
    assert tracked > 0.9 and untracked < 0.8 * tracked, (tracked, untracked)


def test_a_resumed_sequence_follows_a_moving_shape_as_an_uninterrupted_one(mi, tmp_path):
    def frames(renderer, indices):
        return _moving_block(mi, renderer, _scene(), indices)

    straight = frames(_renderer(), range(4))
    first = _renderer()
    frames(first, range(3))
    assert first.poses.poses  # the block moved
    np.savez(tmp_path / "state.npz", **first.state())
    resumed = _renderer()
    resumed.restore(dict(np.load(tmp_path / "state.npz")))
    # a new process loads the scene anew, the block as the XML has it; frame 3 moves it from there
    np.testing.assert_array_equal(frames(resumed, [3])[0], straight[3])


def test_where_only_a_shape_moved_the_pixels_whose_light_changed_get_fresh_samples_first(mi):
    """A still camera over a moving block: the weight the next placement gives the history is far under 1 where the
    block and its shadow moved (the probes' light held, to a power) and near 1 elsewhere (the small box's indirect light
    moves a little everywhere); those pixels read as thin history and get the boost. A light switched brighter changes
    the light one way everywhere: no pixel's history is read as thick, so none gives its fresh samples to another."""
    from gmcpt.temporal.sequence import FRESH_BOOST, HELD_PLACEMENT_POWER, _placed_history, _placement

    renderer = _renderer()
    _moving_block(mi, renderer, _scene(), range(3))
    placing = renderer.placing
    assert placing is not None and placing.max() == 1.0
    held = placing ** (1.0 / HELD_PLACEMENT_POWER)
    assert held.min() < 0.5 and np.median(held) > 0.9
    history = np.full(placing.size, 2.0)
    counts = _placement(_placed_history(history, placing), 2 * placing.size, 2.0, SIZE[::-1], 0,
                        np.ones(placing.size, bool))
    changed = placing * 2.0 < 0.5
    assert changed.any() and counts[changed].min() >= 1 + round(FRESH_BOOST * 2)
    assert counts[changed].mean() >= counts[~changed].mean() + 1 and counts.sum() == 2 * placing.size
    np.testing.assert_array_equal(_placed_history(history, None), history)

    light = _scene()
    lights = _renderer()
    lights.render(light, 0)
    lights.render(light, 1)
    parameters = mi.traverse(light)
    radiance = next(k for k in parameters.keys() if k.endswith("radiance.value") and "light" in k)
    parameters[radiance] = parameters[radiance] * 8
    parameters.update()
    lights.render(light, 2)
    assert lights.placing is not None and np.quantile(lights.placing, 0.9) < 0.05


def test_surface_pixels_without_history_get_more_fresh_samples_within_the_budget():
    from gmcpt.temporal.sequence import FRESH_BOOST, _placement

    history = np.full(100, 6.0)
    history[:10] = 0.0  # a moved object's pixels: their history dropped
    history[90:] = 0.0  # pixels whose centre ray missed: no history ever
    surface = np.arange(100) < 90
    counts = _placement(history, 200, 2.0, (10, 10), 0, surface)
    assert counts.sum() == 200 and counts.min() >= 1
    boost = round(FRESH_BOOST * 2)
    assert boost >= 1 and counts[:10].min() >= counts[90:].min() + boost  # the moved object's pixels, above the misses
    assert counts[10:90].max() <= 2 < counts[:10].min()  # taken from the pixels with history
    # the first frame (no history anywhere) and a frame without surfaces: the even placement
    even = _placement(np.zeros(100), 200, 2.0, (10, 10), 0, surface)
    assert (even == 2).all()
    assert (_placement(history, 200, 2.0, (10, 10), 0, np.zeros(100, bool))
            == _placement(history, 200, 2.0, (10, 10), 0)).all()


def test_a_light_switched_off_or_on_drops_its_history(mi):
    scene = _scene()
    renderer = _renderer()
    parameters = mi.traverse(scene)
    key = next(k for k in parameters.keys() if k.endswith("radiance.value") and "light" in k)
    radiance = mi.Color3f(parameters[key])
    lit = [renderer.render(scene, index)[0].mean() for index in range(3)]
    parameters[key] = mi.Color3f(0.0)
    parameters.update()
    image, info, _ = renderer.render(scene, 3)
    # the directly lit pixels drop for their lighting, the rest (the ceiling, the shadows) as they disagree
    assert image.mean() < 0.02 * np.mean(lit) and info.history_dropped > 0.95 and info.dropped.lighting > 0.5
    assert info.history_decay > 0.85  # the light held in the frame before
    parameters[key] = radiance
    parameters.update()
    image, info, _ = renderer.render(scene, 4)  # the dark frame's history goes, the lit frames' before it stays
    assert abs(image.mean() / np.mean(lit) - 1) < 0.1 and info.dropped.lighting > 0.5
    # the light changed over most of the frame before: older frames count less (their indirect light is stale)
    assert info.history_decay < 0.5 * renderer.settings.decay


def test_history_scaled_by_the_light_held_to_a_power_keeps_its_mean_and_the_light_held():
    """Where only objects moved the history weighs the light held to a power: the weight falls, each pixel's mean and
    the light held (which the carry and the placement read) stay, and what was left out is recorded."""
    from gmcpt.temporal.sequence import DroppedShares, History

    count = np.full(4, 2.0, np.float32)
    total = np.arange(12, dtype=np.float32).reshape(4, 3) * count[:, None]
    history = History(total, count, np.ones(4, bool), np.ones(4, bool), np.zeros((4, 2), np.float32), 2,
                      DroppedShares(0.0, 0.0, 0.0))
    held = np.array([1.0, 0.5, 0.25, 0.0], np.float32)
    scaled = history.scaled(held, 4.0)
    np.testing.assert_allclose(scaled.count, 2.0 * held ** 4)
    np.testing.assert_allclose(scaled.total[:3] / scaled.count[:3, None], total[:3] / count[:3, None], rtol=1e-6)
    np.testing.assert_array_equal(scaled.light_held, held)
    assert abs(scaled.dropped.gradient - (1 - (1 + 0.5 ** 4 + 0.25 ** 4) / 4)) < 1e-6
    np.testing.assert_allclose(history.scaled(held).count, 2.0 * held)


def test_history_whose_light_changed_decays_faster_the_more_samples_a_frame_traces():
    """The more samples a frame traces, the less their noise hides the staleness of older frames' light."""
    few, many = _renderer(budget=1), _renderer(budget=4)
    assert few.decay == many.decay == few.settings.decay  # no light changed: the settings' decay
    few.light_changed = many.light_changed = 0.3
    assert many.decay < few.decay < few.settings.decay


def test_the_jit_gather_keeps_what_the_numpy_tests_keep_and_edges_a_neighbour_s(mi):
    from gmcpt.temporal.reprojection import gather_history, jit_frame
    from gmcpt.temporal.history import DEPTH_TOLERANCE, matches, surfaces, unchanged

    renderer = _renderer()
    renderer.render(_scene(frame=0), 0)
    scene = _scene(frame=2)  # the camera turned two degrees
    renderer.render(scene, 1)
    past, current = renderer.past[0], renderer.past[1]  # frame 1's survey, as the next frame would see it
    lighting = past.signature.lighting.copy()
    lighting[::3] = 4 * lighting[::3] + 0.1  # a light that changed on a third of the past pixels
    # read by pixel, as the numpy tests read (by quarter: test_a_moving_camera_reads_...)
    past = replace(past, signature=replace(past.signature, lighting=lighting), quarters=None)
    floor = 0.01
    seen, source, film = matches(past, surfaces(current.positions, current.normals))
    lit, same = unchanged(past.signature, source, current.signature, seen, film, floor, camera_moved=True)
    gathered = gather_history([(jit_frame(past), 0.5, True, True, None)], current.positions, current.normals,
                              current.signature, floor)
    expected = np.zeros(current.count.size, bool)
    expected[seen[lit & same]] = True
    assert 0.3 < expected.mean() < 0.99 and (lit & same).mean() < 1  # some kept, some not
    nearest = np.zeros(current.count.size, bool)
    nearest[seen] = True
    # where the past pixel the point lands in saw its surface, it decides, as the numpy tests do
    assert np.mean(gathered.latest_seen[nearest] != expected[nearest]) < 1e-3  # float rounding may flip a pixel
    both = expected & gathered.latest_seen
    rows = np.zeros(current.count.size, np.int64)
    rows[seen] = source
    np.testing.assert_allclose(gathered.summed[both, 3], 0.5 * past.count[rows[both]], rtol=1e-6)
    np.testing.assert_allclose(gathered.latest_film[both], film[np.isin(seen, np.flatnonzero(both))], atol=1e-3)
    # where it saw another surface (an edge), another of the four past pixels around the point serves
    edges = np.flatnonzero(gathered.latest_seen & ~nearest)
    assert 0 < edges.size < 0.1 * current.count.size
    landed = gathered.latest_film[edges] - 0.5
    left, top = np.floor(landed[:, 0]).astype(int), np.floor(landed[:, 1]).astype(int)
    width = past.projection.width
    candidates = np.stack([(top + dy) * width + left + dx for dy in (0, 1) for dx in (0, 1)], axis=1)
    distance = np.linalg.norm(past.positions[np.clip(candidates, 0, past.count.size - 1)]
                              - current.positions[edges][:, None], axis=2)
    served = np.abs(0.5 * past.total[np.clip(candidates, 0, past.count.size - 1)]
                    - gathered.summed[edges, None, :3]).max(axis=2) < 1e-5
    away = np.linalg.norm(current.positions[edges] - past.projection.centre, axis=1)
    assert (served & (distance <= DEPTH_TOLERANCE * away[:, None])).any(axis=1).all()  # one of the four, same surface


#: A flat wall facing the camera: film side (pixels), its distance, the focal length in pixels (a pixel 1% of the
#: distance across: neighbours on one surface)
_WALL = (8, 10.0, 100.0)


def _wall() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(film coordinates of the pixel centres (N, 2), where their rays meet :data:`_WALL`'s wall (N, 3), its normals
    (N, 3) float32) of a camera at the origin looking down +z."""
    size, depth, focal = _WALL
    column, row = np.meshgrid(np.arange(size) + 0.5, np.arange(size) + 0.5)
    film = np.stack([column.ravel(), row.ravel()], axis=1)
    positions = np.concatenate([(film - size / 2) * depth / focal, np.full((size * size, 1), depth)], axis=1)
    return film, positions, np.tile([0.0, 0.0, -1.0], (size * size, 1)).astype(np.float32)


def test_a_neighbour_serves_an_edge_only_where_the_camera_moved(mi):
    """Where the past pixel a point lands in saw another surface, a still camera's is an object that moved: no
    neighbour serves (the light around a moved object changes unseen); a moving camera's is an edge, and one does."""
    from gmcpt.temporal.history import PastFrame, Projection, signature
    from gmcpt.temporal.reprojection import gather_history, jit_frame

    size, depth, focal = _WALL
    film, positions, normals = _wall()
    marks = signature(np.ones(size * size, np.float32), np.full(size * size, 0.5, np.float32), size, size)
    edge = 3 * size + 3
    moved_away = positions.copy()
    moved_away[edge] *= 0.5  # the past pixel saw a nearer surface there

    def gathered(shift: float, camera_moved: bool) -> np.ndarray:
        matrix = np.array([[focal, 0, size / 2 + shift, 0], [0, focal, size / 2, 0], [0, 0, 1, 0]], np.float64)
        past = PastFrame(0, np.ones((size * size, 3), np.float32), np.ones(size * size, np.float32),
                         moved_away.astype(np.float32), normals, Projection(matrix, size, size),
                         marks)
        return gather_history([(jit_frame(past), 1.0, True, camera_moved, None)], positions.astype(np.float32),
                              normals, marks, 0.0).latest_seen

    still, panned = gathered(1e-3, False), gathered(0.25, True)  # a still camera's points land on the centres
    assert not still[edge] and still.sum() == size * size - 1
    # a quarter pixel off: the point lands in the past pixel beside (edge + 1) or at the edge; its neighbours serve
    assert panned[edge] and panned[edge - 1]


def test_a_still_camera_s_nearest_pixel_alone_keeps_what_the_four_keep(mi):
    """Where the camera stayed and no mesh moved, the gather reads only the past pixel each point lands in: which
    samples it keeps, from where, and why it drops the others are those of the four-pixel match, at a moved surface
    and a changed light too."""
    import drjit as dr
    from gmcpt.temporal.history import PastFrame, Projection, signature
    from gmcpt.temporal.reprojection import _marks, _match, _vector, jit_frame

    size, depth, focal = _WALL
    film, positions, normals = _wall()
    lighting = np.ones(size * size, np.float32)
    lighting[film[:, 0] > 5] = 2.0  # a patch of light that moved on
    current = signature(lighting, np.full(size * size, 0.5, np.float32), size, size)
    moved_away = positions.copy()
    moved_away[3 * size + 3] *= 0.5  # a surface that moved
    # the points land a rounding's width left of their centres: the four around them start a column to the left
    matrix = np.array([[focal, 0, size / 2 - 1e-3, 0], [0, focal, size / 2 - 1e-3, 0], [0, 0, 1, 0]], np.float64)
    past = jit_frame(PastFrame(0, np.ones((size * size, 3), np.float32), np.ones(size * size, np.float32),
                               moved_away.astype(np.float32), normals, Projection(matrix, size, size),
                               signature(np.ones(size * size, np.float32), np.full(size * size, 0.5, np.float32),
                                         size, size)))
    point, normal = _vector(positions.astype(np.float32), mi.Point3f), _vector(normals, mi.Vector3f)
    floor = dr.opaque(mi.Float, 0.0)
    four, nearest = (_match(past, point, normal, _marks(current), floor, False, nearest_only=only)
                     for only in (False, True))
    held = np.asarray(four.held)
    assert 0 < held.sum() < size * size - 1  # some kept, the moved surface and the changed light not
    for field in ("held", "lit", "same_material", "u", "v"):
        np.testing.assert_array_equal(np.asarray(getattr(nearest, field)), np.asarray(getattr(four, field)))
    np.testing.assert_array_equal(np.asarray(nearest.source)[held], np.asarray(four.source)[held])


def test_a_moving_camera_reads_the_past_samples_that_fell_within_the_pixel(mi):
    """Over half a pixel off, a pixel's footprint on the past film covers halves of two past pixels: read by quarter,
    it takes the samples that fell there, not the nearest past pixel's whole (another mix of an edge inside it)."""
    from gmcpt.temporal.history import PastFrame, Projection, signature
    from gmcpt.temporal.reprojection import gather_history, jit_frame

    size, depth, focal = _WALL
    film, positions, normals = _wall()
    marks = signature(np.ones(size * size, np.float32), np.full(size * size, 0.5, np.float32), size, size)
    shift = 0.55  # current column c lands at past x = c + 1.05
    matrix = np.array([[focal, 0, size / 2 + shift, 0], [0, focal, size / 2, 0], [0, 0, 1, 0]], np.float64)
    past_positions = np.concatenate([(film - [size / 2 + shift, size / 2]) * depth / focal,
                                     np.full((size * size, 1), depth)], axis=1).astype(np.float32)
    # an edge inside past column 5: radiance 1 left of x = 5.5 on the past film, 3 right of it
    column = film[:, 0] - 0.5
    left_half, right_half = np.where(column <= 5, 1.0, 3.0), np.where(column <= 4, 1.0, 3.0)
    quarters = np.zeros((size * size, 4, 4), np.float32)
    for quarter, value in enumerate((left_half, right_half, left_half, right_half)):
        quarters[:, quarter, :3], quarters[:, quarter, 3] = value[:, None], 1.0
    past = PastFrame(0, quarters[:, :, :3].sum(axis=1), quarters[:, :, 3].sum(axis=1), past_positions, normals,
                     Projection(matrix, size, size), marks, quarters)
    pixel = np.flatnonzero((column == 4) & (film[:, 1] == 3.5))[0]  # its footprint: past x in [4.55, 5.55)

    def mean(frame: PastFrame) -> np.ndarray:
        summed = gather_history([(jit_frame(frame), 1.0, True, True, None)], positions.astype(np.float32), normals,
                                marks, 0.0).summed[pixel]
        return summed[:3] / summed[3]

    np.testing.assert_allclose(mean(past), 1.0, rtol=1e-6)  # the halves of past pixels 4 and 5 left of the edge
    np.testing.assert_allclose(mean(replace(past, quarters=None)), 2.0, rtol=1e-6)  # past pixel 5, both sides


def test_from_budget_4_the_carry_fades_where_the_frame_shown_before_is_read_between_pixels(mi):
    """Read half a pixel off its centres, the frame shown before is a Catmull-Rom blur, which carried frame after frame
    stays: from :data:`CARRY_FADE_BUDGET` the carry falls to none there, and stays whole at the centres."""
    from gmcpt.temporal.sequence import CARRY_FADE_BUDGET

    renderer, side = _renderer(), 4
    renderer.shown = (0, np.ones((side, side, 3), np.float32))
    column, row = np.meshgrid(np.arange(side) + 0.5, np.arange(side) + 0.5)
    film = np.stack([column.ravel(), row.ravel()], axis=1).astype(np.float32)
    film[::2, 0] += 0.5  # every other pixel's surface was half a pixel off a past centre
    where = np.ones(side * side, bool)

    def shown(budget: float) -> np.ndarray:
        return renderer._carried(np.zeros((side, side, 3), np.float32), film, where, budget, 0.0)[0][..., 0].ravel()

    faded, whole = shown(CARRY_FADE_BUDGET), shown(1.0)
    assert np.all(faded[::2] == 0) and np.allclose(faded[1::2], 0.5) and np.allclose(whole, 0.5)


def test_a_camera_moved_by_whole_pixels_is_allowed_what_a_moving_one_is(mi):
    """Points land on the past pixels' centres after a move of whole pixels as a still camera's do: a signature that
    changed within the pixel's own spread (which guide rays fall either side of an edge) is held only because the
    camera is known to have moved."""
    from gmcpt.temporal.history import PastFrame, Projection, signature, unchanged
    from gmcpt.temporal.reprojection import gather_history, jit_frame

    size, depth, focal = _WALL
    film, positions, normals = _wall()
    column, row = film[:, 0], film[:, 1]
    albedo = np.full(size * size, 0.5, np.float32)
    lighting = np.where(column >= 4, 2.0, 1.0).astype(np.float32)  # a shadow's edge between columns 3 and 4
    current = signature(lighting, albedo, size, size)
    # the past camera one pixel to the left: current column c is past column c + 1, the edge a column on
    past_lighting = np.where(column >= 5, 2.0, 1.0).astype(np.float32)
    past_lighting[column == 4.5] = 1.5  # the edge's pixel saw it cover half its rays
    matrix = np.array([[focal, 0, size / 2 + 1.0, 0], [0, focal, size / 2, 0], [0, 0, 1, 0]], np.float64)
    shifted_positions = np.concatenate([(film - [size / 2 + 1.0, size / 2]) * depth / focal,
                                        np.full((size * size, 1), depth)], axis=1).astype(np.float32)
    past = PastFrame(0, np.ones((size * size, 3), np.float32), np.ones(size * size, np.float32), shifted_positions,
                     normals, Projection(matrix, size, size), signature(past_lighting, albedo, size, size))
    edge = np.flatnonzero((column == 3.5) & (row == 3.5))[0]

    def held(camera_moved: bool) -> np.ndarray:
        return gather_history([(jit_frame(past), 1.0, True, camera_moved, None)], positions.astype(np.float32), normals,
                              current, 0.0).latest_seen

    moved, still = held(True), held(False)
    assert moved[edge] and not still[edge]
    assert moved.sum() == still.sum() + size  # the edge's column (the last has no past pixel in either)
    landed = film[edge:edge + 1] + [1.0, 0.0]
    for camera_moved, expected in ((True, True), (False, False)):  # the numpy reference agrees
        lit, _ = unchanged(past.signature, np.array([edge + 1]), current, np.array([edge]), landed, 0.0, camera_moved)
        assert lit[0] == expected


def test_a_timed_sequence_sizes_each_frame_from_the_pace_of_the_frames_before():
    from gmcpt.temporal.pace import FramePace

    pace, clock = FramePace(), 0.0
    assert pace.budget(1.0, first=3.0) == 3.0  # nothing measured yet

    def frame(budget, fixed=0.2, per_sample=0.1, gap=0.0):
        nonlocal clock
        started = clock + gap
        clock = started + fixed + per_sample * budget
        pace.record(started, clock, per_sample * budget, budget, 1.0, traced=clock - fixed / 2)

    frame(3.0)
    assert pace.budget(1.0, first=3.0) == pytest.approx(8.0)  # (1 - 0.2) / 0.1
    frame(8.0, gap=0.1)  # the caller's 0.1 s between frames (loading, writing) is part of a frame's period
    assert pace.budget(1.0, first=3.0) == pytest.approx(8.0)  # the least fixed cost of the frames so far
    frame(8.0, gap=50.0)  # a pause is not a frame's cost
    frame(8.0, fixed=2.0, per_sample=0.3)  # one slow frame on a busy machine does not starve the next
    assert pace.budget(1.0, first=3.0) == pytest.approx(8.0)
    frame(8.0, per_sample=0.3)
    frame(8.0, per_sample=0.3)  # slower for good: the budget follows
    assert pace.budget(1.0, first=3.0) == pytest.approx(0.8 / 0.3)
    assert pace.budget(0.01, first=3.0) == 0.25  # the fewest a timed frame spends
    # the tracing ends where the period ends less the least time a frame took after its tracing (0.1 s here)
    assert pace.deadline(1.0, clock + 0.3) == pytest.approx(clock + 0.9)  # a frame that started 0.3 s after
    assert pace.budget_until(clock + 0.9, clock + 0.4) == pytest.approx(0.5 / 0.3)  # what is left buys the samples
    assert pace.deadline(1.0, clock + 5.0) is None  # after a pause the frame traces what it planned
    assert FramePace().deadline(1.0, 0.0) is None

    pace, clock = FramePace(), 0.0
    for budget in (4.0, 20.0):  # a launch of 0.05 s besides 0.01 s a sample: the ramp at the start of a sequence
        frame(budget, fixed=0.1, per_sample=0.01 + 0.05 / budget)
    assert pace.budget(1.0, first=3.0) == pytest.approx((1 - 0.1 - 0.05) / 0.01)


def test_a_timed_frame_traces_in_passes_up_to_its_deadline(mi, monkeypatch):
    import time

    import gmcpt.temporal.sequence as sequence
    from gmcpt.render.kernels import SampleSums
    from gmcpt.render.scene import path_integrator, scene_sensor
    from gmcpt.temporal.sequence import _trace

    starts = []  # when each pass began: a stall inside a pass (a loaded machine) is not a pass begun late
    native, counted = sequence.render_native, SampleSums.trace_counts
    monkeypatch.setattr(sequence, "render_native",
                        lambda *a, **k: starts.append(time.perf_counter()) or native(*a, **k))
    monkeypatch.setattr(SampleSums, "trace_counts",
                        lambda self, *a: starts.append(time.perf_counter()) or counted(self, *a))

    scene = _scene()
    where = (scene, scene_sensor(scene), path_integrator(scene))
    counts = np.full(SIZE[0] * SIZE[1], 3)
    counts[:10] = 5  # pixels without history get more
    untimed = SampleSums(counts.size)
    _trace(untimed, where, counts, 7, None, timed=True)
    assert untimed.samples == counts.sum()
    late = SampleSums(counts.size)
    _trace(late, where, counts, 7, time.perf_counter() - 1.0, timed=True)  # past its deadline: the first pass and
    assert late.samples == counts.size + 2 * 10  # the pixels without history, no more
    deadline = time.perf_counter() + 0.5
    ample = SampleSums(counts.size)
    starts.clear()
    _trace(ample, where, counts, 7, deadline, timed=True)  # time to spare: passes past the plan, none begun late
    assert ample.samples > counts.sum() and len(starts) > 3 and max(starts) < deadline + 0.1
    rest = ample.finite[10:]  # whole passes, then one sample more on a share of the pixels with the time left
    assert rest.max() - rest.min() <= 1 and rest.mean() > 3
    assert (ample.finite[:10] >= rest.min() + 2).all() and (ample.finite[:10] <= rest.max() + 2).all()
    sparse = np.zeros_like(counts)
    sparse[::4] = 1  # a plan of a quarter sample a pixel (read from frames that compiled kernels): made up for
    starved = SampleSums(counts.size)
    _trace(starved, where, sparse, 7, time.perf_counter() + 0.3, timed=True)
    assert starved.finite.min() >= 1 and starved.samples > 2 * counts.size


def test_a_timed_sequence_records_its_time_and_each_frame_its_own_budget(mi):
    scene = _scene()
    renderer = _renderer(time=0.5)
    budgets = [renderer.render(scene, index)[1].budget for index in range(3)]
    assert budgets[0] == 2 and budgets[1] != 2 and budgets[2] != 2
    assert renderer.render(scene, 3)[1].time_short is not None


def _turn(mi, sensor, degrees: float) -> None:
    """Turn ``sensor`` by ``degrees`` about its own up axis, as an animation moves it (``mi.traverse``)."""
    parameters = mi.traverse(sensor)
    matrix = np.asarray(parameters["to_world"].matrix, np.float32).reshape(4, 4)
    turned = mi.ScalarTransform4f(matrix) @ mi.ScalarTransform4f().rotate([0, 1, 0], degrees)
    parameters["to_world"] = type(parameters["to_world"])(turned)
    parameters.update()


def test_a_perspective_camera_s_projection_in_closed_form_is_its_fit(mi):
    from gmcpt.temporal.survey import camera_projection, fitted_projection

    for path in (CORNELL, STILL_LIFE):
        sensor = _scene(path).sensors()[0]
        _turn(mi, sensor, 7.0)
        closed, fitted = camera_projection(sensor), fitted_projection(sensor)
        assert (closed.width, closed.height) == (fitted.width, fitted.height) == SIZE
        np.testing.assert_allclose(closed.matrix / closed.matrix[2, 3], fitted.matrix / fitted.matrix[2, 3],
                                   atol=1e-4 * np.abs(fitted.matrix / fitted.matrix[2, 3]).max())


def _lit_around_the_corner(mi):
    """A floor seen from above whose light comes off a wall out of view, lit by a lamp that faces the wall: no point
    in view sees the lamp, so the lighting signature is 0 everywhere, whatever the lamp does."""
    T = mi.ScalarTransform4f
    return mi.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 4},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": T().look_at(origin=[0, 3, 0], target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": 32, "height": 32, "rfilter": {"type": "box"}}},
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(2),
                  "bsdf": {"type": "diffuse"}},
        "wall": {"type": "rectangle", "to_world": T().translate([1.5, 1, 0]).rotate([0, 1, 0], -90).scale(2),
                 "bsdf": {"type": "diffuse"}},
        "lamp": {"type": "rectangle", "to_world": T().translate([1.3, 1, 0]).rotate([0, 1, 0], 90).scale(0.5),
                 "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 10.0}}},
    })


def test_light_that_reaches_the_view_only_indirectly_is_seen_by_the_probes(mi, monkeypatch):
    import gmcpt.temporal.sequence as sequence
    from gmcpt.render.kernels import render_native
    from gmcpt.render.scene import path_integrator

    def last_frame(scene, integrator):
        renderer = _renderer()
        infos = [renderer.render(scene, index, integrator)[1] for index in range(4)]
        parameters = mi.traverse(scene)
        radiance = mi.Color3f(parameters["lamp.emitter.radiance.value"])
        parameters["lamp.emitter.radiance.value"] = radiance * 4
        parameters.update()
        frame = renderer.render_frame(scene, 4, integrator)
        parameters["lamp.emitter.radiance.value"] = radiance
        parameters.update()
        return infos, frame

    scene = _lit_around_the_corner(mi)
    sensor, integrator = scene.sensors()[0], path_integrator(scene)
    assert not sequence.survey(scene, sensor).lighting.any()  # the signature is blind here
    before = render_native(scene, sensor, integrator, 64, 901).mean()
    infos, frame = last_frame(scene, integrator)
    assert all(info.dropped.gradient == 0 for info in infos)  # nothing changed: the replays agree to the bit
    assert frame.info.dropped.lighting == 0  # four times the light, unseen by the signature
    # three quarters of the light is new: the history weighs a quarter, to HELD_HISTORY_POWER where the signature saw
    # no light change (as where only objects moved): under a tenth of it stays
    assert sequence.HELD_HISTORY_POWER > 1 and 0.9 < frame.info.dropped.gradient < 1.0
    # the same frames with the probes reading no change: the history's old light kept whole
    monkeypatch.setattr(sequence, "changed_share", lambda before, after, shape: np.zeros(shape[0] * shape[1]))
    _, blind = last_frame(scene, integrator)
    assert blind.info.dropped.gradient == 0
    assert frame.layers.radiance.mean() > blind.layers.radiance.mean() + 0.3 * before


def test_a_path_scenes_sequence_takes_its_light_samples_and_another_integrator_traces_as_it_is(mi):
    """A plain ``path`` is traced with :data:`LIGHT_SAMPLES` emitter samples at the first hit (the record says so),
    another frame than with one; an integrator without a twin (``direct``) traces itself, one light sample."""
    from gmcpt.errors import GmcptError
    from gmcpt.temporal.sequence import LIGHT_SAMPLES

    scene = _scene()
    image, info, _ = _renderer().render(scene, 0)
    assert LIGHT_SAMPLES > 1 and info.light_samples == LIGHT_SAMPLES
    one, info, _ = _renderer(light_samples=1).render(scene, 0)
    assert info.light_samples == 1 and not np.array_equal(image, one)
    image, info, _ = _renderer().render(scene, 0, mi.load_dict({"type": "direct"}))
    assert info.light_samples == 1 and np.isfinite(image).all()
    with pytest.raises(GmcptError, match="light samples"):
        _renderer(light_samples=0)
