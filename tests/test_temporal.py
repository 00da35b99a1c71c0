"""Reprojection of past frames (gmcpt.temporal.history): a pinhole fit, exact reuse, and the tests that refuse
history."""
import numpy as np
import pytest

from gmcpt.errors import GmcptError
from gmcpt.temporal.history import PastFrame, agreement, fit_projection, history_weights, reproject
from gmcpt.temporal.reprojection import cubic_sample

from camera_helpers import HEIGHT, WIDTH, camera, centres, wall_frame


def _past(projection, positions, normals, index=0):
    pixels = WIDTH * HEIGHT
    return PastFrame(index, np.arange(pixels * 3, dtype=float).reshape(pixels, 3), np.full(pixels, 2.0),
                     positions, normals, projection)


def test_the_fit_projects_every_pixel_centre_onto_itself():
    projection, positions, _ = wall_frame(camera([0.0, 0.0, 0.0], yaw_degrees=7))
    landed, front = projection.project(positions)
    assert front.all()
    np.testing.assert_allclose(landed, centres(), atol=1e-6)


def test_a_camera_whose_rays_do_not_meet_is_refused():
    film = centres()
    origins = np.stack([film[:, 0], -film[:, 1], np.zeros(len(film))], axis=1)  # orthographic: parallel rays
    directions = np.tile([0.0, 0.0, -1.0], (len(film), 1))
    with pytest.raises(GmcptError, match="pinhole"):
        fit_projection(film, origins, directions, WIDTH, HEIGHT)


def test_a_still_camera_reuses_every_pixel_of_the_past_frame_as_it_was():
    projection, positions, normals = wall_frame(camera([0.0, 0.0, 0.0]))
    source, valid = reproject(_past(projection, positions, normals), positions, normals)
    assert valid.all()
    np.testing.assert_array_equal(source, np.arange(WIDTH * HEIGHT))


def test_a_pan_reuses_only_pixels_that_land_near_a_past_centre_and_never_off_the_film():
    past_projection, past_positions, normals = wall_frame(camera([0.0, 0.0, 0.0]))
    _, positions, _ = wall_frame(camera([0.0, 0.0, 0.0], yaw_degrees=3))  # the wall moves by about a pixel
    past = _past(past_projection, past_positions, normals)
    source, valid = reproject(past, positions, normals)
    assert 0 < valid.mean() < 1
    landed, _ = past_projection.project(positions[valid])
    assert np.abs(landed - centres()[source[valid]]).max() <= 0.5 + 1e-9  # the nearest past pixel, no farther
    np.testing.assert_allclose(past_positions[source[valid]], positions[valid], atol=0.5 * 5 / 20 * 2)


def test_another_surface_or_a_miss_gets_no_history():
    projection, positions, normals = wall_frame(camera([0.0, 0.0, 0.0]))
    past = _past(projection, positions, normals)
    nearer = positions * 0.5  # a surface in front of the wall (same pixels, half the distance)
    assert not reproject(past, nearer, normals)[1].any()
    turned = np.tile([1.0, 0.0, 0.0], (len(normals), 1))
    assert not reproject(past, positions, turned)[1].any()
    missed = positions.copy()
    missed[:5] = np.nan
    assert not reproject(past, missed, normals)[1][:5].any() and reproject(past, missed, normals)[1][5:].all()


def test_history_that_disagrees_with_the_current_samples_is_left_out():
    rng = np.random.default_rng(0)
    current = 0.3 * rng.exponential(size=(48, 48, 3))  # a noisy frame of few samples: heavy-tailed
    agreeing = 0.3 * rng.exponential(size=(48, 48, 3))
    moved_light = agreeing.copy()
    moved_light[:, 24:] *= 8  # the right half was lit far more before
    has = np.ones((48, 48), bool)
    assert agreement(current, agreeing, has).mean() > 0.99  # noise alone drops (almost) nothing
    kept = agreement(current, moved_light, has)
    assert not kept[:, 32:].any() and kept[:, :16].all()
    assert agreement(current, moved_light, np.zeros((48, 48), bool)).all()  # nothing to judge: no refusal


def test_fireflies_among_the_current_samples_are_no_changed_light():
    rng = np.random.default_rng(1)
    current, agreeing = (0.3 * rng.exponential(size=(48, 48, 3)) for _ in range(2))
    flies = rng.random((48, 48)) < 0.004
    current[flies] *= 300  # a few samples that found a light: each its pixel's luminance x300
    has = np.ones((48, 48), bool)
    assert agreement(current, agreeing, has).mean() > 0.99
    lit = agreeing * 8  # the whole frame was lit 8x more before: a change, fireflies or not
    assert not agreement(current, lit, has).any()


def test_a_firefly_in_the_history_keeps_the_history_with_it():
    rng = np.random.default_rng(2)
    current, history = (0.3 * rng.exponential(size=(48, 48, 3)) for _ in range(2))
    flies = rng.random((48, 48)) < 0.004
    history[flies] *= 300  # a past sample that found a light, its pixel 300x its neighbours now
    kept = agreement(current, history, np.ones((48, 48), bool))
    assert kept[flies].all() and kept.mean() > 0.99  # dropping it would take the pixel's other samples too


def test_catmull_rom_reads_pixel_centres_as_they_are_and_a_ramp_between_them():
    rows, columns = np.mgrid[0:12, 0:16].astype(np.float32)
    image = np.stack([columns, rows, 2 * columns + rows + 1], axis=-1)
    centres = np.array([[3.5, 4.5], [10.5, 7.5]])
    np.testing.assert_allclose(cubic_sample(image, centres), image[[4, 7], [3, 10]], atol=1e-5)
    between = np.array([[5.2, 6.9], [8.75, 3.1]])  # away from the edges a ramp is read exactly
    x, y = between[:, 0] - 0.5, between[:, 1] - 0.5
    expected = np.stack([x, y, 2 * x + y + 1], axis=1)
    np.testing.assert_allclose(cubic_sample(image, between), expected, atol=1e-4)


def test_recent_frames_weigh_most():
    assert history_weights([1, 2, 3], 0.5) == [0.5, 0.25, 0.125]
    with pytest.raises(GmcptError, match="decay"):
        history_weights([1], 0.0)


def _edge(width=6, height=4, at=3, low=0.0, high=1.0):
    """A signature with a step from ``low`` to ``high`` at column ``at`` (lighting), flat albedo."""
    from gmcpt.temporal.history import signature

    lighting = np.where(np.arange(width * height) % width < at, low, high).astype(np.float32)
    return signature(lighting, np.full(width * height, 0.5, np.float32), width, height)


def test_a_still_camera_keeps_a_static_edge_and_drops_one_that_moved():
    from gmcpt.temporal.history import unchanged

    pixels = np.arange(24)
    centred = np.stack([pixels % 6 + 0.5, pixels // 6 + 0.5], axis=1).astype(np.float32)
    lit, same = unchanged(_edge(), pixels, _edge(), pixels, centred, 0.0)
    assert lit.all() and same.all()
    # the edge moved by one pixel: only the column it crossed changed, and its wide spread excuses nothing there
    lit, _ = unchanged(_edge(at=3), pixels, _edge(at=2), pixels, centred, 0.0)
    np.testing.assert_array_equal(~lit, pixels % 6 == 2)


def test_a_shift_off_the_past_centre_excuses_what_a_sub_pixel_shift_changes_across_an_edge():
    from gmcpt.temporal.history import unchanged

    pixels = np.arange(24)
    half = np.stack([pixels % 6 + 1.0, pixels // 6 + 0.5], axis=1).astype(np.float32)  # half a pixel off
    lit, _ = unchanged(_edge(at=3), pixels, _edge(at=2), pixels, half, 0.0)
    assert lit.all()
    # a quarter off: the current pixel's own spread is excused whole (any shift changes which of a signature's few
    # guide rays fall on either side of an edge), the past pixel's by half: an edge that moved two pixels is seen
    quarter = half - np.float32([0.25, 0.0])
    lit, _ = unchanged(_edge(at=3), pixels, _edge(at=2), pixels, quarter, 0.0)
    assert lit.all()
    lit, _ = unchanged(_edge(at=4), pixels, _edge(at=2), pixels, quarter, 0.0)
    assert not lit[pixels % 6 == 3].any() and lit[pixels % 6 != 3].all()
    centred = half - np.float32([0.5, 0.0])  # a still camera: no excuse at all
    lit, _ = unchanged(_edge(at=3), pixels, _edge(at=2), pixels, centred, 0.0)
    assert not lit[pixels % 6 == 2].any()


def test_a_switched_light_or_a_changed_material_is_no_longer_the_same():
    from gmcpt.temporal.history import signature, unchanged

    pixels = np.arange(24)
    centred = np.stack([pixels % 6 + 0.5, pixels // 6 + 0.5], axis=1).astype(np.float32)
    on = signature(np.ones(24, np.float32), np.full(24, 0.5, np.float32), 6, 4)
    off = signature(np.zeros(24, np.float32), np.full(24, 0.5, np.float32), 6, 4)
    dimmer = signature(np.full(24, 0.95, np.float32), np.full(24, 0.8, np.float32), 6, 4)
    assert not unchanged(on, pixels, off, pixels, centred, 0.02)[0].any()
    assert not unchanged(off, pixels, on, pixels, centred, 0.02)[0].any()
    lit, same = unchanged(on, pixels, dimmer, pixels, centred, 0.02)  # 5% dimmer light: within the ratio
    assert lit.all() and not same.any()


def test_a_meshs_motion_is_fitted_and_a_point_on_it_taken_back_to_where_it_was(mi):
    from gmcpt.temporal.motion import ShapePoses, affine_fit, points_then, shape_keys

    rng = np.random.default_rng(2)
    before = rng.normal(size=(50, 3))
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    fitted = affine_fit(before, before @ turn.T + [1.0, 2.0, 3.0])
    np.testing.assert_allclose(fitted[:3, :3], turn, atol=1e-9)
    np.testing.assert_allclose(fitted[:3, 3], [1.0, 2.0, 3.0], atol=1e-9)
    flat = before * [1.0, 1.0, 0.0]  # a flat mesh: only its shift is known, and the map stays invertible
    shift = np.eye(4)
    shift[0, 3] = 0.5
    np.testing.assert_allclose(affine_fit(flat, flat + [0.5, 0.0, 0.0]), shift, atol=1e-12)
    # a point on mesh 4, moved by ``fitted`` since the past frame, was where the inverse takes it; others stay
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]], np.float32)
    normals = np.array([[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]], np.float32)
    lanes = {4: np.array([1])}  # pixel 1 is on mesh 4
    then_positions, then_normals = points_then(positions, normals, lanes, {4: fitted}, {})
    np.testing.assert_allclose(then_positions, [[0, 0, 0], [0, 0, 0]], atol=1e-6)
    np.testing.assert_allclose(then_normals, [[0, 1, 0], [1, 0, 0]], atol=1e-6)
    assert points_then(positions, normals, lanes, {4: fitted}, {4: fitted}) is None
    shifted = np.eye(4)
    shifted[:3, 3] = [1.0, 2.0, 3.0]
    assert points_then(positions, normals, lanes, {4: shifted}, {})[1] is None  # moved, not turned

    import drjit as dr
    from gmcpt.render.scene import load_scene
    from conftest import CORNELL

    scene = load_scene(CORNELL, resolution=(16, 16))
    poses = ShapePoses()
    assert poses.update(scene) == {}
    parameters, key = mi.traverse(scene), "short_block.vertex_positions"
    parameters[key] = mi.Float((np.array(parameters[key]).reshape(-1, 3) + [0.0, 0.0, 0.25]).ravel())
    parameters.update()
    moved = poses.update(scene)
    block = [place for place, shape in enumerate(scene.shapes()) if shape.id() == "short_block"]
    assert list(moved) == block
    np.testing.assert_allclose(moved[block[0]][:3, 3], [0.0, 0.0, 0.25], atol=1e-5)
    keys = shape_keys(scene)
    registry = int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(scene.shapes()[block[0]]))[0])
    assert keys[registry] == block[0]
    # the scene loaded again (as a batch loads each frame): its block is back where it was, by the same place
    np.testing.assert_allclose(poses.update(load_scene(CORNELL, resolution=(16, 16)))[block[0]], np.eye(4), atol=1e-5)
