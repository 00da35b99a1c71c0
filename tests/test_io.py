import dataclasses
from pathlib import Path

import numpy as np
import pytest

from conftest import synthetic_frame
from gmcpt.errors import GmcptError
from gmcpt.io.exr import atomic_output, channel_names, check_writable, pack, read_exr, unpack, write_exr


def test_pack_unpack_roundtrip():
    frame, clean = synthetic_frame()
    tensor = pack(frame, clean)
    assert tensor.shape == (*frame.shape, len(channel_names()))
    back, image = unpack(tensor, spp=frame.spp)
    assert np.array_equal(image, clean) and np.array_equal(back.mask, frame.mask)
    assert np.array_equal(back.albedo, frame.albedo) and np.array_equal(back.depth, frame.depth)
    # a frame without a coverage buffer comes back with the 0/1 one its demodulation assumed
    assert np.array_equal(back.coverage, frame.albedo.max(-1) >= 0.02)
    covered = dataclasses.replace(frame, coverage=np.linspace(0, 1, frame.mask.size, dtype=np.float32).reshape(frame.shape))
    assert np.array_equal(unpack(pack(covered, clean))[0].coverage, covered.coverage)


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


def test_atomic_output_turns_a_failed_write_into_one_line_and_keeps_the_old_file(tmp_path):
    target = tmp_path / "keep.exr"
    target.write_bytes(b"old")
    with pytest.raises(GmcptError, match=r"cannot write .*keep.exr: No space left on device"):
        with atomic_output(target) as temporary:
            with open(temporary, "wb") as handle:
                handle.write(b"half")
            raise OSError(28, "No space left on device")
    assert target.read_bytes() == b"old" and list(tmp_path.iterdir()) == [target]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc (a directory nobody can write to)")
def test_check_writable_tries_the_directory_rather_than_trusting_access():
    with pytest.raises(GmcptError, match="cannot write /proc/x.exr"):
        check_writable("/proc/x.exr")


def test_check_writable_leaves_nothing_behind(tmp_path):
    assert check_writable(tmp_path / "x.exr") == tmp_path / "x.exr"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("write", ["check_writable", "atomic_output", "write_together"])
def test_a_signal_just_after_a_temporary_is_made_leaves_none_behind(tmp_path, monkeypatch, write):
    """CI's failure: SIGTERM between check_writable's mkstemp and its unlink left the hidden probe file."""
    import signal
    import tempfile

    from gmcpt.io import files
    from gmcpt.runtime import interrupts

    made = tempfile.mkstemp

    def mkstemp_then_signal(*args, **kwargs):
        result = made(*args, **kwargs)
        signal.raise_signal(signal.SIGTERM)  # the handler runs here unless the signal is held
        return result

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp_then_signal)
    previous = interrupts.install()
    try:
        with pytest.raises(interrupts.Terminated):
            if write == "check_writable":
                files.check_writable(tmp_path / "x.exr")
            elif write == "atomic_output":
                with files.atomic_output(tmp_path / "x.exr") as temporary:
                    Path(temporary).write_bytes(b"new")
            else:
                files.write_together([(tmp_path / "x.exr", lambda name: Path(name).write_bytes(b"new"))])
    finally:
        interrupts.restore(previous)
    assert list(tmp_path.iterdir()) == []
