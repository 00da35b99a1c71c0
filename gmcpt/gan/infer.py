"""Run a generator on a whole sparse frame, and the exposure it runs at."""
from __future__ import annotations

import numpy as np
import torch

from ..frame import SparseFrame
from ..image.domain import WorkingDomain
from ..runtime.workers import map_single_threaded, torch_threads
from .inputs import EXPOSURE_TARGET, as_tensor, exposed, network_arrays, target_exposure, working_image  # noqa: F401
from .model import Generator
from .runtime import CpuNetwork, precomplete_on_cpu

#: PyTorch runs the generator on horizontal bands of about ``BAND_ROWS`` rows, each seeing ``BAND_HALO`` more
#: rows of context on either side, dealt to threads that each run torch on one thread
#: (:func:`gmcpt.runtime.workers.map_single_threaded`), because torch's own threads meet at a barrier after every layer,
#: which stalls on a whole large frame; a frame of one band (under 768 rows) runs on torch's own threads. The
#: bands follow from the frame's height alone, so the thread count moves the output by float rounding only
#: (band sizes and halos measured: docs/experiments.md, "Figures moved out of the code").
BAND_ROWS = 512
BAND_HALO = 64


def memory_format(device: str | torch.device) -> torch.memory_format:
    """The layout the generator runs in on ``device``: channels last (pixel-interleaved) on a CPU, where
    oneDNN's convolutions then need no reorder of their inputs (measured: docs/experiments.md); CUDA keeps the
    contiguous layout (not measured there)."""
    return torch.channels_last if torch.device(device).type == "cpu" else torch.contiguous_format


def prepare(generator: Generator, device: str) -> Generator:
    """``generator`` moved to ``device`` in its :func:`memory_format`, in place, unless its first convolution's
    weights are there already: ``to`` walks every parameter even when nothing moves (0.3 ms a frame)."""
    layout = memory_format(device)
    kernel = next((weight for weight in generator.parameters() if weight.dim() == 4), None)
    moved = kernel is not None and kernel.device.type == torch.device(device).type
    if not (moved and kernel.is_contiguous(memory_format=layout)):
        generator.to(device=device, memory_format=layout)
    return generator


def bands(height: int, multiple: int) -> list[tuple[int, int]]:
    """(first, stop) rows of the generator's bands of a frame ``height`` rows high (a multiple of ``multiple``)."""
    count = max(1, int(height / BAND_ROWS + 0.5))
    cuts = [round(height * index / count / multiple) * multiple for index in range(count + 1)]
    return list(zip(cuts[:-1], cuts[1:]))


def generate(generator: Generator, radiance: torch.Tensor, features: torch.Tensor, threads: int = 1,
             precision: str = "float32", fill: torch.Tensor | None = None) -> torch.Tensor:
    """``generator(radiance, features, fill)`` band by band (:data:`BAND_ROWS`), on ``threads`` threads: bands
    dealt to threads that each run torch on one thread, or one band on ``threads`` torch threads. On a
    GPU (the inputs' device) the same bands run one after another. ``precision`` ``"bfloat16"`` runs
    the generator under autocast (:func:`gmcpt.runtime.device.generator_precision`); the output is float32. The
    inputs are laid out in the device's :func:`memory_format` (the generator: :func:`prepare`). Without a
    ``fill`` (the whole frame's), each band computes its own."""
    height = radiance.shape[2]
    cast = precision == "bfloat16"
    layout_format = memory_format(radiance.device)
    radiance, features = (tensor.contiguous(memory_format=layout_format) for tensor in (radiance, features))

    def band_output(band):
        first, stop = band
        top, bottom = max(0, first - BAND_HALO), min(height, stop + BAND_HALO)
        band_fill = None if fill is None else fill[:, :, top:bottom]
        # autocast is a thread's own setting: entered in the thread that runs the band
        with torch.inference_mode(), torch.autocast(radiance.device.type, torch.bfloat16, enabled=cast):
            output = generator(radiance[:, :, top:bottom], features[:, :, top:bottom], band_fill).float()
        return output[:, :, first - top:stop - top]

    cuts = bands(height, generator.multiple)
    if radiance.device.type != "cpu":
        return torch.cat([band_output(band) for band in cuts], 2)
    if len(cuts) > 1:
        return torch.cat(map_single_threaded(band_output, cuts, threads), 2)
    with torch_threads(threads):  # one band: on torch's own threads (see BAND_ROWS)
        return band_output(cuts[0])


def network_inputs(generator: Generator, frame: SparseFrame, domain: WorkingDomain
                   ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, np.ndarray]:
    """(radiance, features, fill, each (1, C, H', W'), factor (H, W, 3)) of ``frame`` for ``generator``
    (:func:`~gmcpt.gan.inputs.network_arrays`: padded to a multiple of its
    :attr:`~gmcpt.gan.model.Generator.multiple`, the fill made once for the whole frame)."""
    config = generator.config
    *arrays, factor = network_arrays(frame, domain, config.use_variance, config.use_coverage, generator.multiple)
    return (*(as_tensor(array) for array in arrays), factor)


def precomplete(generator: Generator, frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                exposure: float = 1.0, threads: int = 1, precision: str = "float32",
                network: CpuNetwork | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(completed image in the working domain (H, W, 3), 0..255-like; demodulation factor (H, W, 3)).

    The generator sees the frame scaled by ``exposure`` (see :func:`~gmcpt.gan.inputs.target_exposure`); the
    exposure is folded into the returned factor, so ``domain.inverse(working, factor)`` is
    radiance at the frame's own exposure, and ``domain.forward(frame.radiance, factor)`` is
    the frame in the working domain the generator ran in. The inputs are :func:`network_inputs`'s,
    cropped back after. The network runs on ``network`` (the generator compiled for a CPU runtime,
    :func:`gmcpt.gan.runtime.cpu_network`; :func:`~gmcpt.gan.runtime.precomplete_on_cpu`) where given, else in
    PyTorch in bands (:func:`generate`) on the generator's device, in ``precision``.
    """
    if network is not None:
        return precomplete_on_cpu(network, frame, domain, exposure)
    if exposure != 1.0:
        frame = exposed(frame, exposure)
    radiance, features, fill, factor = network_inputs(generator, frame, domain)
    device = next(generator.parameters()).device
    output = generate(generator, radiance.to(device), features.to(device), threads, precision, fill.to(device))
    return working_image(output.permute(0, 2, 3, 1).cpu().numpy(), frame.shape, factor, exposure)
