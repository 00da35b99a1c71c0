"""Movies (gmcpt.io.video, ``gmcpt batch --video``): an MP4 that decodes back to the frames, odd sizes, one-line
refusals, and no file, half-written or clobbered, after a failure."""
import av
import numpy as np
import pytest

from conftest import CORNELL
from test_batch import gmcpt

TINY = ("--res", "16", "16", "--frames", "0:3", "-q")


def decoded(path):
    """(frames as (H, W, 3) uint8 sRGB, frames a second) of the movie at ``path``, through PyAV."""
    with av.open(str(path)) as container:
        rate = container.streams.video[0].average_rate
        frames = [frame.reformat(format="rgb24", src_colorspace="ITU709", src_color_range="MPEG").to_ndarray()
                  for frame in container.decode(video=0)]
    return frames, rate


def pngs(folder):
    from PIL import Image

    return [np.asarray(Image.open(path).convert("RGB")) for path in sorted(folder.glob("*.png"))]


@pytest.mark.parametrize("mode", [("--history", "2", "--budget", "1"), ("--spp", "4", "--method", "pawnnm")],
                         ids=["sequence", "plain"])
def test_batch_video_decodes_to_its_frames(tmp_path, mode):
    out = tmp_path / "out"
    gmcpt("batch", CORNELL, *TINY, *mode, "--out", out, "--video", tmp_path / "movie.mp4", "--fps", "12")
    frames, rate = decoded(tmp_path / "movie.mp4")
    assert len(frames) == 3 and frames[0].shape == (16, 16, 3) and rate == 12
    # the PNGs' sRGB, not linear radiance: off by x264's loss alone
    difference = np.abs(np.stack(frames).astype(float) - np.stack(pngs(out)))
    assert difference.mean() < 6, difference.mean()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["movie.mp4", "out"]  # no temporary left


@pytest.mark.parametrize("video, fps, message", [
    ("movie.avi", "24", "--video is written as H.264 in MP4: give a file name ending in .mp4"),
    ("missing/deeper/movie.mp4", "24", "does not exist"),
    ("afile/movie.mp4", "24", "is not a folder"),
    ("movie.mp4", "0", "--fps must be a frame rate"),
])
def test_batch_bad_video_is_one_line_before_any_work(tmp_path, monkeypatch, capsys, video, fps, message):
    from gmcpt.cli import main

    (tmp_path / "afile").write_text("")
    monkeypatch.chdir(tmp_path)
    assert main(["batch", str(CORNELL), *TINY, "--out", "out", "--video", video, "--fps", fps]) == 2
    error = capsys.readouterr().err
    assert error.startswith("error: ") and error.count("\n") == 1 and message in error, error
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_odd_sizes_are_padded_to_even_and_float_frames_are_tonemapped(tmp_path):
    from gmcpt.io.exr import write_png
    from gmcpt.io.video import write_video

    linear = [np.full((15, 9, 3), value, np.float32) for value in (0.05, 0.2, 0.8)]
    movie = write_video(linear, tmp_path / "odd.mp4", fps=29.97)
    frames, rate = decoded(tmp_path / "odd.mp4")
    assert (movie.frames, movie.width, movie.height) == (3, 10, 16) and frames[0].shape == (16, 10, 3)
    assert float(rate) == pytest.approx(29.97)
    write_png(tmp_path / "middle.png", linear[1])  # the PNG preview's conversion, not a gamma of our own
    assert np.abs(frames[1].astype(float) - pngs(tmp_path)[0][[*range(15), 14]][:, [*range(9), 8]]).max() <= 3


def _old_movie(tmp_path):
    target = tmp_path / "movie.mp4"
    target.write_bytes(b"the movie before")
    return target


def _untouched(tmp_path, target):
    assert target.read_bytes() == b"the movie before"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["movie.mp4"]


def test_frames_of_different_sizes_leave_the_old_movie_as_it_was(tmp_path):
    from gmcpt.errors import GmcptError
    from gmcpt.io.video import write_video

    target = _old_movie(tmp_path)
    frames = [np.zeros((16, 16, 3), np.uint8), np.zeros((16, 16, 3), np.uint8), np.zeros((8, 16, 3), np.uint8)]
    with pytest.raises(GmcptError, match="frame 2 of .* is 16x8, frame 0 is 16x16"):
        write_video(frames, target)
    _untouched(tmp_path, target)


def test_a_failed_encode_leaves_no_file(tmp_path, monkeypatch):
    from gmcpt.errors import GmcptError
    from gmcpt.io.video import write_video

    target = _old_movie(tmp_path)
    calls = []

    def failing(self, frame=None):  # the encoder fails on the third frame, the first two already muxed
        calls.append(frame)
        if len(calls) == 3:
            raise av.error.ExternalError(542398533, "Generic error in an external library")
        return original(self, frame)
    original = av.video.stream.VideoStream.encode
    monkeypatch.setattr(av.video.stream.VideoStream, "encode", failing)
    with pytest.raises(GmcptError, match="cannot encode .*movie.mp4: .*external library") as error:
        write_video([np.zeros((16, 16, 3), np.uint8)] * 4, target)
    assert "\n" not in str(error.value)
    _untouched(tmp_path, target)
    target.unlink()
    calls.clear()
    with pytest.raises(GmcptError):  # nor a new one
        write_video([np.zeros((16, 16, 3), np.uint8)] * 4, target)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("frames, message", [([], "no frames to write"),
                                             (["nope.png"], "cannot read the frame nope.png"),
                                             ([np.zeros((4, 4), np.uint8)], "(H, W, 3)")])
def test_bad_frames_are_one_line_and_no_file(tmp_path, monkeypatch, frames, message):
    from gmcpt.errors import GmcptError
    from gmcpt.io.video import write_video

    monkeypatch.chdir(tmp_path)
    with pytest.raises(GmcptError, match=message.replace("(", r"\(").replace(")", r"\)")):
        write_video(frames, "movie.mp4")
    assert list(tmp_path.iterdir()) == []
