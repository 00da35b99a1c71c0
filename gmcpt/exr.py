"""The multi-layer EXR: its layer layout, reading and writing it, the sRGB PNG preview beside it.

The layout (:data:`LAYERS`) is shared by the ``masked_path`` integrator's output
tensor and the EXR file. Channels, in order (names as tev and Blender group
them, ``layer.channel``)::

    R G B                      completed radiance (linear)
    sparse.R sparse.G sparse.B traced radiance, 0 where not traced
    mask.Y                     1 where traced
    albedo.R albedo.G albedo.B
    normal.X normal.Y normal.Z world-space shading normal
    depth.Y                    hit distance / largest in the image (misses: 1)
    visibility.Y               fraction of shadow rays reaching a light
    variance.Y                 variance of each traced pixel's mean
    coverage.Y                 fraction of feature rays on a diffuse surface (see gmcpt.domain)

Writers write where they are told; callers wrap them in :func:`atomic_output`
(the data lands in a temporary file beside the target and is renamed over it
only when complete), so an error never leaves a half-written or clobbered file.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

import numpy as np

from .domain import frame_coverage
from .errors import GmcptError
from .frame import SparseFrame

LAYERS = (("", "RGB"), ("sparse", "RGB"), ("mask", "Y"), ("albedo", "RGB"), ("normal", "XYZ"),
          ("depth", "Y"), ("visibility", "Y"), ("variance", "Y"), ("coverage", "Y"))


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike):
    """Yield a temporary path next to ``path``; rename it over ``path`` on success.

    An ``OSError`` while creating, writing or renaming (a read-only file system, a full disk)
    becomes a one-line :class:`GmcptError` naming ``path``; ``path`` itself is left as it was.
    """
    path = Path(path)
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    except OSError as error:
        raise _write_error(path, error) from None
    os.close(handle)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; give the usual mode
    try:
        yield temporary
        os.replace(temporary, path)
    except OSError as error:
        raise _write_error(path, error) from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)


def _write_error(path: Path, error: OSError) -> GmcptError:
    return GmcptError(f"cannot write {path}: {error.strerror or error}")


def check_writable(path: str | os.PathLike) -> Path:
    """Fail early, with one line, if ``path`` cannot be created or replaced."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise GmcptError(f"output path {path} is a directory")
    if not parent.is_dir():
        raise GmcptError(f"output directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise GmcptError(f"output directory {parent} is not writable")
    try:  # access() says yes to root, and on /proc: try it
        handle, probe = tempfile.mkstemp(prefix=f".{path.name}.", dir=parent)
        os.close(handle)
        os.unlink(probe)
    except OSError as error:
        raise _write_error(path, error) from None
    return path


def write_exr(path: str | os.PathLike, channels: dict[str, np.ndarray], attributes: dict | None = None) -> None:
    """Write float32 ``channels`` (name -> (H, W) array) as one ZIP-compressed EXR."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update({key: str(value) for key, value in (attributes or {}).items()})
    pixels = {name: np.ascontiguousarray(array, dtype=np.float32) for name, array in channels.items()}
    with OpenEXR.File(header, pixels) as exr:
        exr.write(str(path))


def read_exr(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read every channel of an EXR file as float32 (H, W) arrays."""
    import OpenEXR

    if not Path(path).is_file():
        raise GmcptError(f"EXR file not found: {path}")
    try:
        with OpenEXR.File(str(path), separate_channels=True) as exr:
            return {name: np.asarray(channel.pixels, dtype=np.float32)
                    for name, channel in exr.channels().items()}
    except GmcptError:
        raise
    except Exception as error:
        raise GmcptError(f"cannot read EXR {path}: {error}") from None


def read_rgb_exr(path: str | os.PathLike) -> np.ndarray:
    """The top-level R, G, B channels of an EXR file as (H, W, 3) float32."""
    channels = read_exr(path)
    if not {"R", "G", "B"} <= channels.keys():
        raise GmcptError(f"EXR {path} has no R, G, B channels")
    return np.stack([channels[c] for c in "RGB"], axis=-1)


def write_png(path: str | os.PathLike, linear: np.ndarray) -> None:
    """Write linear (H, W, 3) radiance as an 8-bit sRGB PNG preview.

    Uses Mitsuba's own conversion (clamp to [0, 1], sRGB transfer function), as
    ``mi.util.write_bitmap`` does; it matches :func:`gmcpt.metrics.tonemap`.
    """
    import mitsuba as mi

    bitmap = mi.Bitmap(np.ascontiguousarray(linear, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bitmap = bitmap.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, True)
    bitmap.write(str(path))


def channel_names() -> list[str]:
    """Flat list of channel names, in tensor order."""
    return [f"{layer}.{c}" if layer else c for layer, channels in LAYERS for c in channels]


def pack(frame: SparseFrame, image: np.ndarray) -> np.ndarray:
    """Stack the completed image and the frame's buffers into (H, W, 17) float32."""
    parts = [image, np.where(frame.mask[..., None], frame.radiance, 0.0), frame.mask[..., None],
             frame.albedo, frame.normal, frame.depth[..., None], frame.visibility[..., None],
             frame.variance[..., None], frame_coverage(frame)[..., None]]
    return np.concatenate([np.asarray(p, dtype=np.float32) for p in parts], axis=-1)


def unpack(tensor: np.ndarray, spp: int = 1) -> tuple[SparseFrame, np.ndarray]:
    """Inverse of :func:`pack`: ``(frame, completed image)``."""
    array = np.asarray(tensor, dtype=np.float32)
    expected = len(channel_names())
    if array.ndim != 3 or array.shape[-1] != expected:
        raise ValueError(f"expected an (H, W, {expected}) tensor, got shape {array.shape}")
    image, sparse, mask, albedo, normal, depth, visibility, variance, coverage = np.split(
        array, np.cumsum([len(c) for _, c in LAYERS])[:-1], axis=-1)
    frame = SparseFrame(radiance=sparse, mask=mask[..., 0] > 0.5, variance=variance[..., 0], albedo=albedo,
                        normal=normal, depth=depth[..., 0], visibility=visibility[..., 0], spp=spp,
                        coverage=coverage[..., 0])
    return frame, image
