"""The sensor's film after ``mi.render`` with ``masked_path``: the completed image and its layers, named.

``mi.render`` returns a bare ``(H, W, 17)`` tensor, and ``mi.util.write_bitmap`` names a bare tensor's
channels ``ch00``...``ch16``; Mitsuba names channels through a film (``Film.prepare(aov_names)``), as its
own integrators leave their image in the sensor's film. :func:`fill_film` does the same with the packed
tensor (:func:`gmcpt.io.exr.pack`), so that, after ``mi.render``::

    film = scene.sensors()[0].film()
    film.bitmap()    # an mi.Bitmap: R, G, B (the completed image), then sparse.R, ..., coverage.Y
    film.develop()   # the tensor mi.render returned (for the film's pixel format)
    mi.util.write_bitmap("x.exr", film.bitmap())   # the layers of ``gmcpt render``'s EXR, float32

(with ``write_async=False`` where the same process reads the file back: with Mitsuba 3.9.1 the
asynchronous write was still unreadable 2 s later, and complete once the process had exited).

The channel names are :func:`gmcpt.io.exr.channel_names`; the integrator's ``aov_names()`` is all of them
after R, G, B, so ``mi.Bitmap(image, channel_names=["R", "G", "B", *integrator.aov_names()])`` names
the returned tensor the same way.
"""
from __future__ import annotations

import mitsuba as mi
import numpy as np

from ..errors import GmcptError
from .exr import channel_names, named_channels


def fill_film(film: mi.Film, tensor) -> None:
    """Make ``film`` hold ``tensor`` (:func:`gmcpt.io.exr.pack`'s layout, the film's crop size) alone, its
    layers named; the alpha of a film with one (``rgba``) is 1: the pipeline renders no coverage alpha."""
    channels = named_channels(tensor)
    height, width = channels["R"].shape
    if (width, height) != tuple(int(side) for side in film.crop_size()):
        raise GmcptError(f"a {width}x{height} image does not fit the film's {film.crop_size()} crop")
    # hdrfilm's storage: R, G, B, an alpha where the film has one, the sample weight W, then the AOVs
    base = "RGBAW" if mi.has_flag(film.flags(), mi.FilmFlags.Alpha) else "RGBW"
    names = [*base, *channel_names()[3:]]
    count = film.prepare(channel_names()[3:])  # a fresh, zeroed storage: the film holds this frame only
    if count != len(names):
        raise GmcptError(f"masked_path writes into R, G, B films such as hdrfilm; the {film.class_name()} film "
                         f"has {count} channels, not {len(names)}")
    ones = np.ones((height, width), np.float32)  # alpha and weight: every pixel whole and opaque
    storage = np.stack([channels.get(name, ones) for name in names], axis=-1)
    film.put_block(mi.ImageBlock(mi.TensorXf(storage), film.crop_offset()))
