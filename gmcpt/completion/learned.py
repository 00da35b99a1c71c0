"""Learned completion: ``gan`` (GAN pre-completion alone) and ``gan_pawnnm`` (the paper's full method).

``gan`` runs the shipped generator (:mod:`gmcpt.gan`) on the sparse frame in
the working domain and returns its output for every pixel: the traced pixels
are replaced too, since the generator also denoises them (docs/design.md section 3: putting
the 16-spp samples back costs 1-3 dB). ``gan_pawnnm`` hands that
pre-completion to the low-rank refinement
(:func:`gmcpt.completion.matrix.refine_low_rank`).

Both take ``weights=`` (a shipped name such as ``gan-cpu`` or a ``.pt`` path;
default :data:`gmcpt.gan.weights.DEFAULT_WEIGHTS`).

The generator runs band by band (:func:`gmcpt.gan.infer.generate`) on as many
threads as torch is set to use (``$GMCPT_TORCH_THREADS`` overrides), each band
with torch on one thread (:mod:`gmcpt.workers` says why), in bfloat16 on a CPU that has it
(:func:`gmcpt.device.generator_precision`).
"""
from __future__ import annotations

import os
import time
from dataclasses import replace

import numpy as np

from ..device import completion_device, generator_precision
from ..domain import WorkingDomain
from ..frame import SparseFrame
from ..lowrank.params import DEFAULT as LOW_RANK_DEFAULT
from ..lowrank.noise import blend_samples, working_variance
from . import Completion, register_method

#: The low-rank stage after the GAN pre-completion runs 1 iteration, not the 11 that ``pawnnm`` runs
#: after its classical fill: each iteration pulls the estimate towards the patch groups' low-rank fixed
#: point, which a good pre-completion is already closer to than to that point. Chosen on the dataset's
#: validation split (10 scenes, mean PSNR dB, version-3 features and the weights trained on them): gan
#: alone 29.76; gan_pawnnm at 1 iteration 30.32, 2: 29.82, 3: 29.64, 4: 29.53, 6: 29.48 (without the
#: split's one very noisy scene, 1000007: 31.73; 32.34, 31.83, 31.62, 31.51, 31.45). On the 5 evaluation
#: scenes at rates 0.2/0.3/0.4: 1 iteration 33.63/34.06/34.43, 2: 33.38/33.86/34.18, 4: 33.01/33.56/34.03.
#: With a single iteration the threshold weight ``w0`` sets how hard the patch groups are denoised; a
#: quarter of ``pawnnm``'s (which starts from a noisier fill and relaxes ``w0`` over its iterations)
#: does best (validation, the 0.90 M-parameter gan-cpu of 2026-11-23: w0 10000 31.34 dB, 5000 31.46,
#: 2500 31.50, 1000 31.42; on the 5 evaluation scenes 33.91/34.39/34.78, 33.96/34.45/34.88,
#: 33.96/34.47/34.93, 33.89/34.43/34.92).
#: Then (2026-11-25, the 5 evaluation scenes, two_pass masks, 5-component matching signal): the Wiener
#: pass's noise scale is half ``pawnnm``'s (2: 34.72/35.48/35.81 dB, 1: 34.77/35.56/35.94, with the
#: generator of 2026-11-23); with the slim generator, groups of 12 patches instead of 16 and ``w0``
#: scaled with them (a squared singular value grows with K) score the same (16: 34.59/35.40/35.77,
#: 12 and w0 1875: 34.58/35.40/35.78; 12 and 2500: 34.57/35.38/35.75) in two thirds of the low-rank
#: stage's time; 8 and 1250: 34.53/35.33/35.73.
GAN_PAWNNM_PARAMS = replace(LOW_RANK_DEFAULT, iterations=1, w0=1875.0, group_size=12, wiener=1.0)


def generator_fill(frame: SparseFrame, domain: WorkingDomain = WorkingDomain(),
                   weights: str | None = None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(working-domain image (H, W, 3), demodulation factor, timings): the generator's output at every pixel.

    The generator runs on the frame brought to :data:`~gmcpt.gan.infer.EXPOSURE_TARGET`
    (:func:`~gmcpt.gan.infer.target_exposure`); the exposure is folded into the returned factor, so
    ``domain.inverse(working, factor)`` is radiance at the frame's own exposure.
    """
    import torch

    from ..gan.infer import precomplete, prepare, target_exposure
    from ..gan.weights import load_generator

    start = time.perf_counter()
    generator, _ = load_generator(weights)
    device = completion_device()
    prepare(generator, device)  # in place: the cached generator stays on that device, in its layout there
    loaded = time.perf_counter()
    threads = int(os.environ.get("GMCPT_TORCH_THREADS", torch.get_num_threads()))
    working, factor = precomplete(generator, frame, domain, target_exposure(frame), threads,
                                  generator_precision(device))
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

    The output is the low-rank stage's, as in the paper. Mixing the GAN output back in
    (``b * gan + (1 - b) * low-rank``) was measured with an earlier gan-cpu and 11 iterations and
    lost on every bundled scene but the still life (cornell-box at rate 0.3: b = 0 33.67 dB,
    0.25 33.14, 0.5 31.62; breakfast-room-open 25.38 / 24.21 / 22.93), so there is no such option.
    """
    from .matrix import LOW_RANK_DOMAIN, refine_low_rank

    working, factor, timings = gan_precompletion(frame, domain, weights)
    gan_image = domain.inverse(working, factor)
    # the low-rank stage works in its own domain (see LOW_RANK_DOMAIN)
    low_rank_working = LOW_RANK_DOMAIN.forward(gan_image, LOW_RANK_DOMAIN.frame_factor(frame))
    result = refine_low_rank(frame, low_rank_working, LOW_RANK_DOMAIN, params or GAN_PAWNNM_PARAMS)
    result.timings.update(timings)
    return result
