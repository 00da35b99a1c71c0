"""Completion, then a denoiser: ``gan_oidn`` (the default) and ``gan_pawnnm_oidn``.

The fill of ``gan`` or ``gan_pawnnm`` stands at the untraced pixels, each traced pixel gets its own
path-traced samples back, and Intel Open Image Denoise (:func:`gmcpt.image.denoise.denoise_oidn`, with
the feature pass's albedo and normal as guides) filters the whole frame. The completion methods'
own denoising of the traced pixels is dropped on purpose: OIDN denoises Monte Carlo noise far
better than it cleans up an image that is already smooth (OIDN over ``gan_pawnnm``'s own output
gains nothing), and the fill gives it what it cannot have at an untraced pixel.

Measured on the 5 evaluation scenes (256x256, 16 spp per traced pixel, two_pass masks; mean PSNR dB at
rates 0.2/0.3/0.4): ``gan`` 33.47/34.08/34.63, ``gan_pawnnm`` 34.56/35.41/36.01,
``gan_oidn`` 34.84/36.02/36.62, ``gan_pawnnm_oidn`` 35.09/36.19/36.74; path tracing at the same samples
+ OIDN 34.27/35.29/35.55 (docs/experiments.md, docs/results.md). ``gan_oidn`` is the default: better than ``gan_pawnnm``
and faster (no low-rank stage; OIDN's filter costs about what the generator does).
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..frame import SparseFrame
from ..image.denoise import denoise_oidn
from ..image.domain import WorkingDomain
from . import Completion, register_method
from .learned import complete_gan_pawnnm, generator_fill


def oidn_guide_rays(frame: SparseFrame) -> int:
    """The rays a pixel OIDN is told the frame's guides are the mean of (:func:`gmcpt.image.denoise.denoise_oidn`): the
    feature pass's where every pixel was traced; 0 over a fill, where clean guides lost (docs/experiments.md)."""
    return (frame.info.feature_spp or 0) if frame.mask.all() else 0


def denoise_over_fill(frame: SparseFrame, fill: Callable[[], Completion]) -> Completion:
    """OIDN over the frame's traced samples, with the image of ``fill()`` at the untraced pixels. A frame
    with every pixel traced (a budget's dense frame) has nothing to fill: ``fill`` is not called, so the
    generator does not run (0.04 s at 256x256, seconds at 1920x1080) for an output nobody reads."""
    if frame.mask.all():
        filled, noisy = Completion(frame.radiance, {}), frame.radiance
    else:
        filled = fill()
        noisy = np.where(frame.mask[..., None], frame.radiance, filled.image)
    start = time.perf_counter()
    image = denoise_oidn(noisy, frame.albedo, frame.normal, oidn_guide_rays(frame))
    return Completion(image, {**filled.timings, "denoise_s": time.perf_counter() - start})


@register_method("gan_oidn", min_size=8,
                 summary="GAN fill, traced samples put back, Intel OIDN over the frame (default)")
def complete_gan_oidn(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(),
                      weights: str | None = None) -> Completion:
    """``gan``'s fill, the traced samples, then OIDN (:func:`denoise_over_fill`). The generator's output
    goes in as it is: ``gan`` blends the samples back only at the traced pixels, which OIDN gets raw."""
    def fill() -> Completion:
        working, factor, timings = generator_fill(frame, domain, weights)
        return Completion(domain.inverse(working, factor), timings)

    return denoise_over_fill(frame, fill)


@register_method("gan_pawnnm_oidn", min_size=8,
                 summary="gan_pawnnm's fill, traced samples put back, Intel OIDN over the frame")
def complete_gan_pawnnm_oidn(frame: SparseFrame, *, domain: WorkingDomain = WorkingDomain(),
                             weights: str | None = None, params=None) -> Completion:
    """``gan_pawnnm``'s fill, the traced samples, then OIDN (:func:`denoise_over_fill`)."""
    return denoise_over_fill(frame, lambda: complete_gan_pawnnm(frame, domain=domain, weights=weights, params=params))
