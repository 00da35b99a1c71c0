"""Run a generator on a whole sparse frame."""
from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F

from ..domain import WorkingDomain
from ..frame import SparseFrame
from .data import SCALE, frame_inputs
from .model import Generator


def precomplete(generator: Generator, frame: SparseFrame, domain: WorkingDomain = WorkingDomain()
                ) -> tuple[np.ndarray, np.ndarray]:
    """(completed image in the working domain (H, W, 3), 0..255-like; demodulation factor (H, W, 3)).

    The frame is padded (reflect) to a multiple of the generator's
    :attr:`~gmcpt.gan.model.Generator.multiple` and cropped back.
    """
    radiance, features, factor = frame_inputs(frame, domain, generator.config.use_variance)
    height, width = frame.shape
    multiple = generator.multiple
    pad = (0, -width % multiple, 0, -height % multiple)
    mode = "reflect" if min(height, width) > multiple else "replicate"
    with torch.inference_mode():
        output = generator(F.pad(radiance, pad, mode=mode), F.pad(features, pad, mode=mode))
    working = output[0, :, :height, :width].permute(1, 2, 0).numpy() * SCALE
    return np.maximum(working, 0.0).astype(np.float32), factor
