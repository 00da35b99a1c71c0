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
    coverage.Y                 fraction of feature rays on a diffuse surface (see gmcpt.image.domain)

Writers write where they are told; callers write through :mod:`gmcpt.io.files`
(the data lands in a temporary file beside the target and is renamed over it
only when complete), so an error never leaves a half-written or clobbered file.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from ..errors import BadValue, GmcptError
from ..frame import SparseFrame
from ..image.domain import frame_coverage
from .files import atomic_output, captured_output, check_writable  # noqa: F401  (atomic_output, check_writable: re-exported)

LAYERS = (("", "RGB"), ("sparse", "RGB"), ("mask", "Y"), ("albedo", "RGB"), ("normal", "XYZ"),
          ("depth", "Y"), ("visibility", "Y"), ("variance", "Y"), ("coverage", "Y"))


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
    with captured_output() as printed:  # OpenEXR prints its own lines about a damaged file
        try:
            with OpenEXR.File(str(path), separate_channels=True) as exr:
                channels = {name: np.asarray(channel.pixels, dtype=np.float32)
                            for name, channel in exr.channels().items()}
            error = None
        except Exception as raised:
            error = raised
    if error is None:  # what it said about a file that still read
        sys.stdout.write(printed.get(1, ""))
        sys.stderr.write(printed.get(2, ""))
        return channels
    detail = next((line for line in printed.get(2, "").splitlines() if line.strip()), "").removeprefix(f"{path}: ")
    raise GmcptError(f"cannot read EXR {path} (truncated or not an EXR file): "
                     + " ".join((detail or str(error)).split()))


def read_rgb_exr(path: str | os.PathLike) -> np.ndarray:
    """The top-level R, G, B channels of an EXR file as (H, W, 3) float32."""
    channels = read_exr(path)
    if not {"R", "G", "B"} <= channels.keys():
        raise GmcptError(f"EXR {path} has no R, G, B channels")
    return np.stack([channels[c] for c in "RGB"], axis=-1)


def write_png(path: str | os.PathLike, linear: np.ndarray) -> None:
    """Write linear (H, W, 3) radiance as an 8-bit sRGB PNG preview.

    Uses Mitsuba's own conversion (clamp to [0, 1], sRGB transfer function), as
    ``mi.util.write_bitmap`` does; it matches :func:`gmcpt.image.metrics.tonemap`.
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


def _packed(tensor) -> np.ndarray:
    """``tensor`` (a NumPy array, a Mitsuba tensor) as float32, checked to have :func:`pack`'s channels."""
    array = np.asarray(tensor, dtype=np.float32)
    expected = len(channel_names())
    if array.ndim != 3 or array.shape[-1] != expected:
        raise BadValue(f"expected an (H, W, {expected}) tensor, got shape {array.shape}")
    return array


def named_channels(tensor) -> dict[str, np.ndarray]:
    """The channels of a :func:`pack` tensor (or of ``mi.render`` with ``masked_path``) by name, as
    :func:`channel_names` and the EXR name them: ``{"R": (H, W) array, ..., "coverage.Y": ...}``."""
    array = _packed(tensor)
    return {name: array[..., index] for index, name in enumerate(channel_names())}


def unpack(tensor, spp: int = 1) -> tuple[SparseFrame, np.ndarray]:
    """Inverse of :func:`pack`: ``(frame, completed image)``; the documented way to read what ``mi.render``
    returns with ``masked_path``::

        frame, image = unpack(mi.render(scene))  # frame.mask, frame.albedo, ...; image: (H, W, 3)

    :func:`named_channels` gives the same layers by their EXR names, and the sensor's film holds them too
    (``mi.util.write_bitmap("x.exr", scene.sensors()[0].film().bitmap())``: see :mod:`gmcpt.io.film`)."""
    array = _packed(tensor)
    image, sparse, mask, albedo, normal, depth, visibility, variance, coverage = np.split(
        array, np.cumsum([len(c) for _, c in LAYERS])[:-1], axis=-1)
    frame = SparseFrame(radiance=sparse, mask=mask[..., 0] > 0.5, variance=variance[..., 0], albedo=albedo,
                        normal=normal, depth=depth[..., 0], visibility=visibility[..., 0], spp=spp,
                        coverage=coverage[..., 0])
    return frame, image
