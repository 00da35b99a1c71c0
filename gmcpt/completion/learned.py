"""Learned completion: ``gan`` (GAN pre-completion alone) and ``gan_pawnnm`` (the paper's full method).

``gan`` runs the shipped generator (:mod:`gmcpt.gan`) on the sparse frame in
the working domain and returns its output for every pixel: the traced pixels
are replaced too, since the generator also denoises them (docs/design.md section 3: putting
the 16-spp samples back costs 1-3 dB). ``gan_pawnnm`` hands that
pre-completion to the low-rank refinement
(:func:`gmcpt.completion.matrix.refine_low_rank`).

Both take ``weights=`` (a shipped name such as ``gan-cpu`` or a ``.pt`` path;
default :data:`gmcpt.gan.weights.DEFAULT_WEIGHTS`).

On a CPU the generator's network runs on OpenVINO (:mod:`gmcpt.gan.runtime`, converted once per weights
file and kept on disk; no torch then) on the threads OpenVINO chooses, else in PyTorch band by band
(:func:`gmcpt.gan.infer.generate`) on as many threads as torch is set to use; ``$GMCPT_TORCH_THREADS``
overrides both. It runs in bfloat16 on a CPU that has it (:func:`gmcpt.runtime.device.generator_precision`).
"""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..frame import SparseFrame
from ..image.domain import WorkingDomain
from ..lowrank.noise import blend_samples, working_variance
from ..lowrank.params import DEFAULT as LOW_RANK_DEFAULT
from ..runtime.device import completion_device, generator_precision, generator_threads
from ..runtime.workers import threads_setting
from . import Completion, register_method

#: The low-rank stage after the GAN pre-completion: one iteration with a lighter threshold, because a good
#: pre-completion is already closer to the image than the patch groups' low-rank fixed point that more
#: iterations pull it to (the sweeps of iterations, w0, group size and Wiener scale: docs/experiments.md,
#: "Figures moved out of the code").
GAN_PAWNNM_PARAMS = replace(LOW_RANK_DEFAULT, iterations=1, w0=1875.0, group_size=12, wiener=1.0)


def generator_fill(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                   weights: str | None = None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(working-domain image (H, W, 3), demodulation factor, timings): the generator's output at every pixel.

    The generator runs on the frame brought to :data:`~gmcpt.gan.infer.EXPOSURE_TARGET`
    (:func:`~gmcpt.gan.infer.target_exposure`); the exposure is folded into the returned factor, so
    ``domain.inverse(working, factor)`` is radiance at the frame's own exposure.
    """
    from ..gan.inputs import target_exposure
    from ..gan.runtime import cpu_network, precomplete_on_cpu

    start = time.perf_counter()
    device = completion_device()
    precision = generator_precision(device)
    network = cpu_network(weights, precision, threads_setting()) if device == "cpu" else None
    if network is not None:  # no torch in the process for this
        loaded = time.perf_counter()
        working, factor = precomplete_on_cpu(network, frame, domain, target_exposure(frame))
    else:
        from ..gan.infer import precomplete, prepare
        from ..gan.weights import load_generator

        generator, _ = load_generator(weights)
        prepare(generator, device)  # in place: the cached generator stays on that device, in its layout there
        loaded = time.perf_counter()
        working, factor = precomplete(generator, frame, domain, target_exposure(frame), generator_threads(),
                                      precision)
    return working, factor, {"load_weights_s": loaded - start, "pre_completion_s": time.perf_counter() - loaded}


def gan_precompletion(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                      weights: str | None = None) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`generator_fill`, with the traced pixels' samples blended back by
    :func:`~gmcpt.lowrank.noise.blend_samples` (the untraced pixels are the generator's)."""
    working, factor, timings = generator_fill(frame, domain, weights)
    start = time.perf_counter()
    observed = domain.forward_traced(frame.radiance, factor, frame.mask)  # the generator's domain, exposure folded in
    working = blend_samples(working, observed, frame.mask, working_variance(frame, domain, observed, factor))
    timings["pre_completion_s"] += time.perf_counter() - start
    return working, factor, timings


@register_method("gan", min_size=8, summary="GAN pre-completion alone (fills and denoises every pixel)")
def complete_gan(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(), weights: str | None = None) -> Completion:
    """GAN pre-completion alone."""
    working, factor, timings = gan_precompletion(frame, domain, weights)
    return Completion(domain.inverse(working, factor), timings)


@register_method("gan_pawnnm", min_size=max(8, LOW_RANK_DEFAULT.patch_size),
                 summary="GAN pre-completion + block matching + PAWNNM (the paper's full method)")
def complete_gan_pawnnm(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(), weights: str | None = None,
                        params=None) -> Completion:
    """GAN pre-completion, then PAWNNM low-rank refinement (``params``, default :data:`GAN_PAWNNM_PARAMS`).

    The output is the low-rank stage's, as in the paper: mixing the GAN output back in lost on every
    bundled scene but the still life, so there is no such option (docs/experiments.md).
    """
    from .matrix import LOW_RANK_DOMAIN, refine_low_rank

    working, factor, timings = gan_precompletion(frame, domain, weights)
    gan_image = domain.inverse(working, factor)
    # the low-rank stage works in its own domain (see LOW_RANK_DOMAIN)
    low_rank_working = LOW_RANK_DOMAIN.forward(gan_image, LOW_RANK_DOMAIN.frame_factor(frame))
    result = refine_low_rank(frame, low_rank_working, LOW_RANK_DOMAIN, params or GAN_PAWNNM_PARAMS)
    result.timings.update(timings)
    return result
