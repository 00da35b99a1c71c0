"""Run a generator on a whole sparse frame, and the exposure it runs at."""
from __future__ import annotations

import dataclasses

import numpy as np
import torch
import torch.nn.functional as F

from ..domain import WorkingDomain, channel_mean
from ..frame import SparseFrame
from ..workers import map_single_threaded, torch_threads
from .inputs import SCALE, frame_inputs
from .model import Generator

#: Brightness the product brings a frame to before the generator sees it: the 95th percentile of
#: the traced pixels' mean radiance (the statistic the dataset builder sets, to 0.4-1.2, when it
#: picks each training scene's exposure). Chosen on the dataset's validation split with the
#: shipped gan-cpu weights (mean PSNR of the 10 val scenes: no exposure 27.58 dB; target 0.8
#: 27.67, 1.5 27.89, 2.5 27.93, 4 27.91): brighter frames put more of the image on the
#: logarithmic part of the working domain, where noise is closer to uniform.
EXPOSURE_TARGET = 2.5

#: The generator runs on horizontal bands of about ``BAND_ROWS`` rows, each seeing ``BAND_HALO`` more
#: rows of context on either side, dealt to the threads (:func:`gmcpt.workers.map_single_threaded`). The
#: bands follow from the frame's height alone, so the thread count moves the output by float rounding only. Measured
#: on the still life's 1024x1024 frame, 2 cores: the whole frame 2.4-2.8 s; 2 bands 1.38-1.44 s, 4 bands
#: 1.46-1.59 s, 8 bands 2.04-2.17 s. A halo of 64 rows (8 cells of the coarsest level) leaves the output
#: within 3e-4 of the whole frame's (on 0..1.3; 32 rows: 1.4e-2). A frame of one band (under 768 rows)
#: runs on torch's own threads instead: at 256x256, 2 threads 0.073-0.082 s against 0.10-0.11 on one
#: (outputs within 3e-7), where two bands, with their halos, took 0.096-0.108 s. Torch's threads meet at a
#: barrier after every layer, which stalls while another process holds a core, but a small frame's
#: generator is a tenth of a second.
BAND_ROWS = 512
BAND_HALO = 64


def target_exposure(frame: SparseFrame, target: float = EXPOSURE_TARGET) -> float:
    """The factor that brings the 95th percentile of the traced pixels' mean radiance to ``target``.

    1 for a frame with no traced pixels; clipped to [1e-2, 1e3] like the dataset's exposures.
    """
    if not frame.mask.any():
        return 1.0
    level = float(np.percentile(channel_mean(frame.radiance[frame.mask]), 95))
    return float(np.clip(target / max(level, 1e-6), 1e-2, 1e3))


def exposed(frame: SparseFrame, exposure: float) -> SparseFrame:
    """The frame with its radiance scaled by ``exposure`` (and its variance by ``exposure ** 2``)."""
    return dataclasses.replace(frame, radiance=(frame.radiance * exposure).astype(np.float32),
                               variance=(frame.variance * exposure ** 2).astype(np.float32))


def memory_format(device: str | torch.device) -> torch.memory_format:
    """The layout the generator runs in on ``device``: channels last (pixel-interleaved) on a CPU, where
    oneDNN's convolutions need no reorder of their inputs then. Measured with the shipped generator on the
    still life's 256x256 frame (2 threads, bfloat16, the fill left out): 24.6 -> 21.2 ms; the whole
    pre-completion 4-7 % faster at 256x256 and 1024x1024. CUDA keeps the contiguous layout (not measured
    there)."""
    return torch.channels_last if torch.device(device).type == "cpu" else torch.contiguous_format


def prepare(generator: Generator, device: str) -> Generator:
    """``generator`` moved to ``device`` in its :func:`memory_format`, in place (a no-op once done)."""
    return generator.to(device=device, memory_format=memory_format(device))


def bands(height: int, multiple: int) -> list[tuple[int, int]]:
    """(first, stop) rows of the generator's bands of a frame ``height`` rows high (a multiple of ``multiple``)."""
    count = max(1, int(height / BAND_ROWS + 0.5))
    cuts = [round(height * index / count / multiple) * multiple for index in range(count + 1)]
    return list(zip(cuts[:-1], cuts[1:]))


def generate(generator: Generator, radiance: torch.Tensor, features: torch.Tensor, threads: int = 1,
             precision: str = "float32") -> torch.Tensor:
    """``generator(radiance, features)`` band by band (:data:`BAND_ROWS`), on ``threads`` threads: bands
    dealt to threads that each run torch on one thread, or one band on ``threads`` torch threads. On a
    GPU (the inputs' device) the same bands run one after another. ``precision`` ``"bfloat16"`` runs
    the generator under autocast (:func:`gmcpt.device.generator_precision`); the output is float32. The
    inputs are laid out in the device's :func:`memory_format` (the generator: :func:`prepare`)."""
    height = radiance.shape[2]
    cast = precision == "bfloat16"
    layout_format = memory_format(radiance.device)
    radiance, features = (tensor.contiguous(memory_format=layout_format) for tensor in (radiance, features))

    def band_output(band):
        first, stop = band
        top, bottom = max(0, first - BAND_HALO), min(height, stop + BAND_HALO)
        # autocast is a thread's own setting: entered in the thread that runs the band
        with torch.inference_mode(), torch.autocast(radiance.device.type, torch.bfloat16, enabled=cast):
            output = generator(radiance[:, :, top:bottom], features[:, :, top:bottom]).float()
        return output[:, :, first - top:stop - top]

    cuts = bands(height, generator.multiple)
    if radiance.device.type != "cpu":
        return torch.cat([band_output(band) for band in cuts], 2)
    if len(cuts) > 1:
        return torch.cat(map_single_threaded(band_output, cuts, threads), 2)
    with torch_threads(threads):  # one band: on torch's own threads (see BAND_ROWS)
        return band_output(cuts[0])


def precomplete(generator: Generator, frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                exposure: float = 1.0, threads: int = 1, precision: str = "float32") -> tuple[np.ndarray, np.ndarray]:
    """(completed image in the working domain (H, W, 3), 0..255-like; demodulation factor (H, W, 3)).

    The generator sees the frame scaled by ``exposure`` (see :func:`target_exposure`); the
    exposure is folded into the returned factor, so ``domain.inverse(working, factor)`` is
    radiance at the frame's own exposure, and ``domain.forward(frame.radiance, factor)`` is
    the frame in the working domain the generator ran in. The frame is padded (reflect) to a
    multiple of the generator's :attr:`~gmcpt.gan.model.Generator.multiple` and cropped back. The
    generator runs in bands (:func:`generate`) on ``threads`` threads, on the generator's device, in
    ``precision``.
    """
    if exposure != 1.0:
        frame = exposed(frame, exposure)
    radiance, features, factor = frame_inputs(frame, domain, generator.config.use_variance,
                                               generator.config.use_coverage)
    height, width = frame.shape
    multiple = generator.multiple
    pad = (0, -width % multiple, 0, -height % multiple)
    mode = "reflect" if min(height, width) > multiple else "replicate"
    if any(pad):
        radiance, features = F.pad(radiance, pad, mode=mode), F.pad(features, pad, mode=mode)
    device = next(generator.parameters()).device
    output = generate(generator, radiance.to(device), features.to(device), threads, precision)
    working = output[0, :, :height, :width].permute(1, 2, 0).cpu().numpy() * SCALE
    return np.maximum(working, 0.0).astype(np.float32), factor / np.float32(exposure)
