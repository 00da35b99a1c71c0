import numpy as np
import pytest

from conftest import synthetic_frame
from gmcpt.errors import GmcptError
from gmcpt.imageio import atomic_output, read_exr, write_exr
from gmcpt.layers import channel_names, pack, unpack


def test_pack_unpack_roundtrip():
    frame, clean = synthetic_frame()
    tensor = pack(frame, clean)
    assert tensor.shape == (*frame.shape, len(channel_names()))
    back, image = unpack(tensor, spp=frame.spp)
    assert np.array_equal(image, clean) and np.array_equal(back.mask, frame.mask)
    assert np.array_equal(back.albedo, frame.albedo) and np.array_equal(back.depth, frame.depth)


def test_exr_roundtrip_keeps_layer_names(tmp_path):
    frame, clean = synthetic_frame()
    tensor = pack(frame, clean)
    channels = {name: tensor[..., i] for i, name in enumerate(channel_names())}
    write_exr(tmp_path / "x.exr", channels)
    back = read_exr(tmp_path / "x.exr")
    assert set(back) == set(channels)
    assert all(np.array_equal(back[name], channels[name]) for name in channels)


def test_atomic_output_leaves_old_file_on_error(tmp_path):
    target = tmp_path / "keep.exr"
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        with atomic_output(target) as temporary:
            with open(temporary, "wb") as handle:
                handle.write(b"half")
            raise RuntimeError("disk full")
    assert target.read_bytes() == b"old" and list(tmp_path.iterdir()) == [target]


def test_read_exr_errors(tmp_path):
    with pytest.raises(GmcptError, match="not found"):
        read_exr(tmp_path / "missing.exr")
    (tmp_path / "bad.exr").write_text("nope")
    with pytest.raises(GmcptError, match="cannot read EXR"):
        read_exr(tmp_path / "bad.exr")
