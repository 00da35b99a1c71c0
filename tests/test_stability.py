"""Flicker figures (gmcpt.evaluation.stability): in place and along the motion, and read against two references."""
import numpy as np

from gmcpt.evaluation.stability import FrameGeometry, screen_flicker, surface_flicker
from gmcpt.metrics import tonemap

from camera_helpers import HEIGHT, WIDTH, camera, wall_frame

FRAMES = 30


def _geometries(step=0.0):
    """A camera sliding along x by ``step`` scene units a frame over a wall: one :class:`FrameGeometry` a frame."""
    frames = [wall_frame(camera([step * t, 0.0, 0.0])) for t in range(FRAMES)]
    return [FrameGeometry(positions, normals, projection) for projection, positions, normals in frames]


def _image(values):
    return np.repeat(values.reshape(HEIGHT, WIDTH, 1), 3, axis=2).astype(np.float32)


def _on_the_wall(geometry, phase=0.0):
    """A smooth pattern fixed to the wall, as seen by the frame."""
    x, y = geometry.positions[:, 0], geometry.positions[:, 1]
    return 0.4 + 0.2 * np.sin(1.3 * x + phase) * np.cos(1.1 * y)


def test_an_image_that_is_its_reference_does_not_flicker():
    geometries = _geometries(0.05)
    references = [_image(_on_the_wall(g)) for g in geometries]
    assert screen_flicker(references, references) == 0.0
    assert surface_flicker(references, references, geometries) == 0.0


def test_noise_new_every_frame_flickers_at_sqrt_2_of_its_error_in_place_and_along_the_motion():
    geometries, rng = _geometries(0.0), np.random.default_rng(1)
    references = [_image(np.full(WIDTH * HEIGHT, 0.3)) for _ in geometries]
    images = [r + rng.normal(0, 0.02, r.shape).astype(np.float32) for r in references]
    rms = 100 * np.sqrt(np.mean([(tonemap(i) - tonemap(r)) ** 2 for i, r in zip(images, references)]))
    for figure in (screen_flicker(images, references), surface_flicker(images, references, geometries)):
        assert abs(figure / (np.sqrt(2) * rms) - 1) < 0.05


def test_an_error_that_stays_on_its_surface_flickers_in_place_on_a_moving_camera_but_not_along_the_motion():
    geometries = _geometries(0.15)  # about half a pixel a frame
    references = [_image(_on_the_wall(g)) for g in geometries]
    images = [_image(_on_the_wall(g) + 0.1 * np.sin(1.5 * g.positions[:, 0])) for g in geometries]
    in_place, along = screen_flicker(images, references), surface_flicker(images, references, geometries)
    assert in_place > 1.0
    assert along < 0.15 * in_place


def test_two_noisy_references_read_the_flicker_a_clean_one_gives():
    geometries, rng = _geometries(0.0), np.random.default_rng(2)
    clean = [_image(_on_the_wall(g, phase=0.1 * t)) for t, g in enumerate(geometries)]  # a light that changes
    images = [c + rng.normal(0, 0.03, c.shape).astype(np.float32) for c in clean]
    first, second = ([c + rng.normal(0, 0.03, c.shape).astype(np.float32) for c in clean] for _ in range(2))
    truth = surface_flicker(images, clean, geometries)
    assert surface_flicker(images, first, geometries) > 1.3 * truth  # one noisy reference overstates it
    assert abs(surface_flicker(images, first, geometries, second) / truth - 1) < 0.08
    assert abs(screen_flicker(images, first, second) / screen_flicker(images, clean) - 1) < 0.08
