"""Run a generator on a whole sparse frame, and the exposure it runs at."""
from __future__ import annotations

import dataclasses

import numpy as np
import torch
import torch.nn.functional as F

from ..domain import WorkingDomain
from ..frame import SparseFrame
from .data import SCALE, frame_inputs
from .model import Generator

#: Brightness the product brings a frame to before the generator sees it: the 95th percentile of
#: the traced pixels' mean radiance (the statistic the dataset builder sets, to 0.4-1.2, when it
#: picks each training scene's exposure). Chosen on the dataset's validation split with the
#: shipped gan-cpu weights (mean PSNR of the 10 val scenes: no exposure 27.58 dB; target 0.8
#: 27.67, 1.5 27.89, 2.5 27.93, 4 27.91): brighter frames put more of the image on the
#: logarithmic part of the working domain, where noise is closer to uniform.
EXPOSURE_TARGET = 2.5


def target_exposure(frame: SparseFrame, target: float = EXPOSURE_TARGET) -> float:
    """The factor that brings the 95th percentile of the traced pixels' mean radiance to ``target``.

    1 for a frame with no traced pixels; clipped to [1e-2, 1e3] like the dataset's exposures.
    """
    if not frame.mask.any():
        return 1.0
    level = float(np.percentile(frame.radiance[frame.mask].mean(axis=-1), 95))
    return float(np.clip(target / max(level, 1e-6), 1e-2, 1e3))


def exposed(frame: SparseFrame, exposure: float) -> SparseFrame:
    """The frame with its radiance scaled by ``exposure`` (and its variance by ``exposure ** 2``)."""
    return dataclasses.replace(frame, radiance=(frame.radiance * exposure).astype(np.float32),
                               variance=(frame.variance * exposure ** 2).astype(np.float32))


def precomplete(generator: Generator, frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                exposure: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """(completed image in the working domain (H, W, 3), 0..255-like; demodulation factor (H, W, 3)).

    The generator sees the frame scaled by ``exposure`` (see :func:`target_exposure`); the
    exposure is folded into the returned factor, so ``domain.inverse(working, factor)`` is
    radiance at the frame's own exposure, and ``domain.forward(frame.radiance, factor)`` is
    the frame in the working domain the generator ran in. The frame is padded (reflect) to a
    multiple of the generator's :attr:`~gmcpt.gan.model.Generator.multiple` and cropped back.
    """
    if exposure != 1.0:
        frame = exposed(frame, exposure)
    radiance, features, factor = frame_inputs(frame, domain, generator.config.use_variance,
                                               generator.config.use_coverage)
    height, width = frame.shape
    multiple = generator.multiple
    pad = (0, -width % multiple, 0, -height % multiple)
    mode = "reflect" if min(height, width) > multiple else "replicate"
    with torch.inference_mode():
        output = generator(F.pad(radiance, pad, mode=mode), F.pad(features, pad, mode=mode))
    working = output[0, :, :height, :width].permute(1, 2, 0).numpy() * SCALE
    return np.maximum(working, 0.0).astype(np.float32), factor / np.float32(exposure)
