"""Completion over overlapping tiles: spans, blending, and no seams."""
import numpy as np
import pytest

from gmcpt.completion import complete
from gmcpt.completion.tiles import _ramp, tile_spans
from gmcpt.errors import GmcptError
from gmcpt.frame import SparseFrame


@pytest.mark.parametrize("length,tile,overlap", [(100, 100, 16), (101, 64, 16), (1080, 256, 32), (3840, 512, 32)])
def test_spans_cover_the_axis_with_the_overlap(length, tile, overlap):
    spans = tile_spans(length, tile, overlap)
    assert spans[0][0] == 0 and spans[-1][1] == length
    sides = {stop - start for start, stop in spans}
    assert len(sides) == 1 and sides.pop() <= tile
    assert len(spans) == 1 or sum(stop - start for start, stop in spans) < length + len(spans) * overlap
    assert all(previous[1] - following[0] >= overlap for previous, following in zip(spans, spans[1:]))
    total = np.zeros(length)
    for index, (start, stop) in enumerate(spans):
        total[start:stop] += _ramp(spans, index, length)
    assert np.allclose(total, 1.0, atol=1e-5)  # the ramps cross-fade: a partition of unity


def gradient_frame(size=160, seed=0):
    """A smooth diagonal gradient under flat features, 30 % of the pixels traced, with a little noise."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:size, 0:size] / size
    truth = np.stack([0.2 + 0.6 * x, 0.3 + 0.4 * y, 0.5 + 0.2 * (x + y) / 2], axis=-1).astype(np.float32)
    mask = rng.random((size, size)) < 0.3
    noisy = truth * (1 + 0.02 * rng.standard_normal((size, size, 1)))
    normal = np.zeros((size, size, 3), np.float32)
    normal[..., 2] = 1
    frame = SparseFrame(radiance=np.where(mask[..., None], noisy, 0).astype(np.float32), mask=mask,
                        variance=np.where(mask, 1e-4, 0).astype(np.float32),
                        albedo=np.full((size, size, 3), 0.5, np.float32), normal=normal,
                        depth=np.full((size, size), 0.5, np.float32), visibility=np.ones((size, size), np.float32),
                        spp=16, coverage=np.ones((size, size), np.float32))
    return frame, truth


@pytest.mark.parametrize("method", ["interp", "pawnnm"])
def test_tiled_gradient_has_no_step_at_tile_borders(method):
    frame, truth = gradient_frame()
    whole = complete(frame, method).image
    tiled = complete(frame, method, tile=96).image
    assert tiled.shape == whole.shape and np.isfinite(tiled).all()
    # steps between neighbouring columns / rows, beyond the gradient's own slope
    spans = tile_spans(frame.shape[0], 96, 32)
    borders = sorted({edge for start, stop in spans[1:] for edge in (start, start + 1)}
                     | {edge for start, stop in spans[:-1] for edge in (stop - 1, stop)})
    for axis in (0, 1):
        step = np.abs(np.diff(tiled - truth, axis=axis)).mean(axis=(1 - axis, 2))
        at_borders = step[[edge - 1 for edge in borders if 0 < edge < len(step) + 1]]
        interior = np.delete(step, [edge - 1 for edge in borders if 0 < edge < len(step) + 1])
        assert at_borders.max() <= 1.5 * interior.max()
    # and the tiled image is about as close to the truth as the whole-frame one
    assert np.abs(tiled - truth).mean() < 1.3 * np.abs(whole - truth).mean() + 1e-3


def test_a_frame_that_fits_one_tile_is_completed_whole():
    frame, _ = gradient_frame(size=64)
    assert np.array_equal(complete(frame, "interp", tile=96).image, complete(frame, "interp").image)


def test_too_small_a_tile_is_refused():
    frame, _ = gradient_frame(size=128)
    with pytest.raises(GmcptError, match="too small"):
        complete(frame, "interp", tile=16)


@pytest.mark.parametrize("tile", [-1, 8, 63, 2.5])
def test_bad_tile_values_are_refused(tile):
    from gmcpt.completion.tiles import check_tile

    with pytest.raises(GmcptError, match="tile must be 0"):
        check_tile(tile)


def test_cli_tiles_a_frame_larger_than_the_tile(tmp_path):
    """The command line completes in tiles, records the tile, and refuses a bad one in one line."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    scene = root / "scenes" / "cornell-box" / "scene.xml"
    command = [sys.executable, str(root / "render_and_complete.py"), str(scene), "--res", "96", "72", "--spp", "2",
               "--method", "interp", "-q"]
    done = subprocess.run(command + ["--tile", "64", "--out", str(tmp_path / "tiled.exr")], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    record = json.loads((tmp_path / "tiled.json").read_text())
    assert record["parameters"]["tile"] == 64
    bad = subprocess.run(command + ["--tile", "10", "--out", str(tmp_path / "bad.exr")], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "tile" in bad.stderr
    assert not (tmp_path / "bad.exr").exists()
