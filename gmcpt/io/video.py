"""Movies of a sequence's frames: H.264 in an MP4, in sRGB, through PyAV (which carries its own FFmpeg).

    write_video(sorted(Path("out/anim").glob("*.png")), "out/anim.mp4", fps=24)

PyAV over imageio-ffmpeg: it encodes in this process (an error is an exception, not a pipe to a child's
stderr), installs in less room and encodes as fast or faster (docs/experiments.md, "The movie writer").

- Frames are 8-bit sRGB PNG files (the ``.png`` preview a render writes beside its EXR), 8-bit sRGB arrays, or
  linear float arrays, which go through the PNG preview's own conversion (:func:`gmcpt.io.exr.write_png`: clamp to
  [0, 1], the sRGB curve), so the movie shows what the PNGs show.
- The stream is yuv420p (what every player plays), converted with the BT.709 matrix and tagged as BT.709
  primaries, the sRGB transfer curve and limited range: sRGB's primaries are BT.709's, so a player shows the
  frames' colours. yuv420p halves the chroma in both directions and x264 then refuses an odd width or height:
  such frames get one more column or row, a copy of the last, and the movie is that much larger.
- The movie is encoded into a temporary file beside ``path`` and renamed over it once complete
  (:func:`gmcpt.io.files.atomic_output`): a failed encode leaves neither a half-written movie nor a clobbered one.
  Bad input is one :class:`GmcptError` line.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Iterable, Union

import numpy as np

from ..errors import GmcptError

Frame = Union[np.ndarray, str, os.PathLike]
SUFFIX = ".mp4"
#: x264's constant rate factor: near the threshold where its loss shows (its default, 23, smooths the
#: per-pixel noise and flicker that these movies are watched for)
CRF = 18
#: the range of frame rates taken: a rate outside it is a typo, not a movie
MAX_FPS = 1000.0
#: the stream's colour tags, FFmpeg's numbers: BT.709 primaries (sRGB's), sRGB's transfer curve (IEC 61966-2-1),
#: the BT.709 matrix the frames are converted with, limited ("MPEG") range
COLOUR_TAGS = {"color_primaries": 1, "color_trc": 13, "colorspace": 1, "color_range": 1}


@dataclass(frozen=True)
class Movie:
    """What :func:`write_video` wrote: the file, its frame count and its size (even: see the module's docstring)."""

    path: Path
    frames: int
    width: int
    height: int


def check_video_path(path: str | os.PathLike, option: str = "the movie") -> Path:
    """``path`` if a movie can be written there: an ``.mp4`` name whose folder exists or can be made and is
    writable (:func:`gmcpt.io.files.check_output`); else one line, before any work."""
    from .files import check_output

    path = Path(path)
    if path.suffix.lower() != SUFFIX:
        raise GmcptError(f"{option} is written as H.264 in MP4: give a file name ending in {SUFFIX}, got {path}")
    return check_output(path)


def check_fps(fps: float, option: str = "fps") -> Fraction:
    """The frame rate as the fraction a stream takes (29.97 is 2997/100); one line where it is not a rate."""
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 0 < fps <= MAX_FPS):
        raise GmcptError(f"{option} must be a frame rate in (0, {MAX_FPS:g}] frames a second, got {fps}")
    return Fraction(fps).limit_denominator(1001)


def srgb8(frame: Frame) -> np.ndarray:
    """``frame`` as (H, W, 3) uint8 sRGB: a PNG file read, a uint8 array as it is, a float array as linear
    radiance converted as the PNG preview is (:func:`gmcpt.io.exr.write_png`)."""
    if isinstance(frame, (str, os.PathLike)):
        from PIL import Image, UnidentifiedImageError

        try:
            with Image.open(frame) as image:
                return np.asarray(image.convert("RGB"))
        except (OSError, UnidentifiedImageError) as error:
            raise GmcptError(f"cannot read the frame {frame}: {getattr(error, 'strerror', None) or error}") from None
    array = np.asarray(frame)
    if array.ndim != 3 or array.shape[-1] != 3 or array.shape[0] == 0 or array.shape[1] == 0:
        raise GmcptError(f"a frame is an (H, W, 3) image, got shape {array.shape}")
    if array.dtype == np.uint8:
        return array
    import mitsuba as mi

    bitmap = mi.Bitmap(np.ascontiguousarray(array, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    return np.asarray(bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True))


def even(image: np.ndarray) -> np.ndarray:
    """``image`` with its last column and row repeated where its width or height is odd (yuv420p needs even)."""
    height, width = image.shape[:2]
    if height % 2 == 0 and width % 2 == 0:
        return image
    return np.pad(image, ((0, height % 2), (0, width % 2), (0, 0)), mode="edge")


def _same_size(image: np.ndarray, first: tuple[int, ...], index: int, path: Path) -> np.ndarray:
    if image.shape != first:
        raise GmcptError(f"frame {index} of {path} is {image.shape[1]}x{image.shape[0]}, frame 0 is "
                         f"{first[1]}x{first[0]}: a movie's frames have one size")
    return image


def _encode(frames: Iterable[Frame], temporary: str, rate: Fraction, path: Path) -> tuple[int, tuple[int, ...]]:
    """Encode ``frames`` into ``temporary``; returns (frames written, the first frame's shape)."""
    import av

    count, first = 0, None
    with av.open(temporary, "w", format="mp4") as container:
        stream = container.add_stream("libx264", rate=rate, options={"crf": str(CRF)})
        for count, frame in enumerate(frames, 1):
            image = srgb8(frame)
            if first is None:
                first = image.shape
                stream.height, stream.width = even(image).shape[:2]
                stream.pix_fmt = "yuv420p"
                for name, value in COLOUR_TAGS.items():
                    setattr(stream.codec_context, name, value)
            picture = av.VideoFrame.from_ndarray(even(_same_size(image, first, count - 1, path)), format="rgb24")
            picture = picture.reformat(format="yuv420p", dst_colorspace="ITU709", dst_color_range="MPEG")
            container.mux(stream.encode(picture))
        if first is None:
            raise GmcptError(f"no frames to write to {path}")
        container.mux(stream.encode())
    return count, first


def write_video(frames: Iterable[Frame], path: str | os.PathLike, fps: float = 24) -> Movie:
    """Write ``frames`` (in order: PNG paths or arrays, see the module's docstring) to ``path`` as an H.264 MP4 at
    ``fps`` frames a second; the frames are read one at a time. Returns what it wrote.

    Raises
    ------
    GmcptError
        One line: a name without ``.mp4``, a folder that is missing or not writable, a bad rate, no frames, frames
        of different sizes, an unreadable frame, a failed encode. ``path`` is then as it was.
    """
    import av

    from .files import atomic_output, check_writable

    path = check_writable(check_video_path(path))
    rate = check_fps(fps)
    with atomic_output(path) as temporary:
        try:
            count, (height, width, _) = _encode(frames, temporary, rate, path)
        except av.FFmpegError as error:
            raise GmcptError(f"cannot encode {path}: {' '.join(str(error).split())}") from None
    return Movie(path, count, width + width % 2, height + height % 2)
