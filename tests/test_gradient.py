"""Temporal gradients (gmcpt.temporal.gradient): the probes' pixels and the share of the light that changed."""
import numpy as np
import pytest

from gmcpt.temporal.gradient import GRADIENT_RADIUS, STRATUM, Probe, changed_share, coherent_share, probe_pixels

SHAPE = (31, 40)  # a row and a column past the last whole block


def test_one_probe_a_block_never_where_the_last_probe_was():
    rows, columns = SHAPE[0] // STRATUM, SHAPE[1] // STRATUM
    first = probe_pixels(SHAPE, 1)
    assert first.size == rows * columns and np.unique(first).size == first.size
    y, x = np.divmod(first, SHAPE[1])
    blocks = (y // STRATUM) * columns + x // STRATUM
    assert sorted(blocks) == list(range(rows * columns)) and y.max() < rows * STRATUM
    np.testing.assert_array_equal(probe_pixels(SHAPE, 1), first)  # same seed, same pixels
    following = probe_pixels(SHAPE, 2, avoid=first)
    assert following.size == first.size and not np.isin(following, first).any()
    assert not probe_pixels((2, 40), 1).size  # a film narrower than a block has none


def test_no_change_reads_zero_and_a_light_halved_in_one_corner_reads_a_half_there_only():
    rows, columns = SHAPE[0] // STRATUM, SHAPE[1] // STRATUM
    rng = np.random.default_rng(0)
    before = rng.exponential(1.0, (rows * columns, 3)).astype(np.float32)
    assert not changed_share(before, before.copy(), SHAPE).any()
    after = before.copy().reshape(rows, columns, 3)
    after[:4, :4] *= 0.5  # the top left 4x4 blocks
    share = changed_share(before, after.reshape(-1, 3), SHAPE).reshape(SHAPE)
    assert abs(share[0, 0] - 0.5) < 1e-6  # every block within reach changed by half
    far = (4 + GRADIENT_RADIUS) * STRATUM
    assert not share[far:, :].any() and not share[:, far:].any()
    assert share[-1, -1] == share[-2, -2]  # past the last whole block: the nearest block's
    after = after.reshape(-1, 3)
    after[0] = np.nan  # a non-finite sample is no probe, not a change
    np.testing.assert_allclose(changed_share(before, after, SHAPE).reshape(SHAPE)[0, 0], 0.5, atol=1e-6)
    switched = changed_share(before, np.zeros_like(before), SHAPE)
    np.testing.assert_allclose(switched, 1.0)  # a light switched off: all of it changed


def test_the_coherent_share_reads_a_light_dimmed_one_way_and_not_shadow_rays_that_flipped_at_random():
    """Paths whose shadow ray flipped either way (a light that moved, the same random numbers) read as much change
    unsigned as a light dimmed by half; signed, less their noise, they read next to none, and the dimming still
    reads."""
    rows, columns = SHAPE[0] // STRATUM, SHAPE[1] // STRATUM
    rng = np.random.default_rng(1)
    before = rng.exponential(1.0, (rows * columns, 3)).astype(np.float32)
    flipped = np.where(rng.random((rows * columns, 1)) < 0.5, 0.5, 1.5).astype(np.float32)
    assert changed_share(before, before * flipped, SHAPE).mean() > 0.3
    assert coherent_share(before, before * flipped, SHAPE).mean() < 0.05
    assert not coherent_share(before, before.copy(), SHAPE).any()
    after = before.copy().reshape(rows, columns, 3)
    after[:4, :4] *= 0.5
    share = coherent_share(before, after.reshape(-1, 3), SHAPE).reshape(SHAPE)
    assert 0.3 < share[0, 0] < 0.5  # half of it changed, less the noise a sum of few probes could hold
    far = (4 + GRADIENT_RADIUS) * STRATUM
    assert not share[far:, :].any() and not share[:, far:].any()


def test_a_probe_replays_in_the_next_frame_of_a_camera_that_stayed_only():
    matrix = np.arange(12, dtype=np.float64).reshape(3, 4)
    probe = Probe(4, 7, np.arange(3), np.zeros((3, 3), np.float32), matrix, SHAPE)
    assert probe.replays_in(5, matrix.copy(), SHAPE)
    assert not probe.replays_in(6, matrix, SHAPE) and not probe.replays_in(5, matrix, (SHAPE[0], SHAPE[1] + 1))
    moved = matrix.copy()
    moved[0, 3] += 1e-3
    assert not probe.replays_in(5, moved, SHAPE)


def test_a_group_traced_again_in_its_lanes_with_its_seed_gives_the_same_samples(mi):
    from conftest import CORNELL
    from gmcpt.render.kernels import trace_counts_after
    from gmcpt.render.scene import load_scene, path_integrator

    scene = load_scene(CORNELL, resolution=(16, 12))
    sensor, integrator = scene.sensors()[0], path_integrator(scene)
    size = 16 * 12
    probe, other = np.arange(0, size, 9), np.arange(3, size, 9)
    counts = np.full(size, 2)
    # the probe in the second slot behind another group, with the frame's own samples after them
    first = trace_counts_after(scene, sensor, integrator, counts, 11, [(other, 5), (probe, 7)])
    # traced again: another group ahead of it, other samples after it, another seed for them
    again = trace_counts_after(scene, sensor, integrator, np.ones(size, np.int64), 12,
                               [(other[::-1].copy(), 6), (probe, 7)])
    np.testing.assert_array_equal(first[3][1], again[3][1])
    assert not np.array_equal(first[3][0], again[3][0])  # the first slot's seed and pixels differ: other samples
    assert first[2].sum() == counts.sum() + probe.size + other.size  # every lane counts: groups and counts


def test_groups_ahead_replay_in_a_pass_of_several_parts_and_too_many_for_one_launch_stop(mi, monkeypatch):
    from conftest import CORNELL
    from gmcpt.errors import GmcptError
    from gmcpt.render import kernels
    from gmcpt.render.scene import load_scene, path_integrator

    scene = load_scene(CORNELL, resolution=(16, 12))
    sensor, integrator = scene.sensors()[0], path_integrator(scene)
    size = 16 * 12
    probe, other = np.arange(0, size, 9), np.arange(3, size, 9)
    alone = kernels.trace_counts_after(scene, sensor, integrator, np.zeros(size, np.int64), 11,
                                       [(other, 5), (probe, 7)])
    counts = np.zeros(size, np.int64)
    counts[:20] = 1  # 20 lanes behind the groups' 44: an even split in two would cut the groups
    monkeypatch.setattr(kernels, "MAX_LANES", 50)
    split = kernels.trace_counts_after(scene, sensor, integrator, counts, 11, [(other, 5), (probe, 7)])
    np.testing.assert_array_equal(split[3][1], alone[3][1])
    np.testing.assert_array_equal(split[3][0], alone[3][0])
    assert split[2].sum() == counts.sum() + probe.size + other.size
    monkeypatch.setattr(kernels, "MAX_LANES", 40)
    with pytest.raises(GmcptError, match="probe lanes"):
        kernels.trace_counts_after(scene, sensor, integrator, counts, 11, [(other, 5), (probe, 7)])
