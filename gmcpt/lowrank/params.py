"""Settings of the patch-group low-rank completion (:func:`~gmcpt.lowrank.pawnnm.complete_low_rank`)
and the presets measured for it: the paper's literal settings, the tuned default and the NNM ablation.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

__all__ = ["LowRankParams", "PAPER_PRESET", "DEFAULT", "NNM_PRESET"]


@dataclass(frozen=True)
class LowRankParams:
    """Settings of :func:`complete_low_rank`.

    Attributes
    ----------
    patch_size : int
        Side of the square patches (paper: n_p = m_p, "try 5-8").
    step : int
        Stride of the reference-patch grid, ``1 <= step < patch_size``; the
        last row / column of patches is always included.  The paper asks for
        ``step < patch_size / 2`` in section III-B but overlaps patches "by two
        pixels" in section IV-C; PAPER_PRESET uses 3, DEFAULT 5.
    search_radius : int
        Half side of the square search window for block matching.
    group_size : int
        K, patches per group (reference included).
    iterations : int
        k, outer iterations of Algorithm 1.
    w0 : float
        Initial threshold weight, on the scale of the working domain
        (an 8-bit-like 0..255 range).  For ``threshold="weighted"`` a
        singular value sigma survives only if ``sigma**2 > w`` (roughly), so
        w is a squared singular value; for ``"constant"`` it is a singular value.
    c : float
        Weight shrink factor per iteration, ``w <- c w`` (paper: 0.9).
    eps : float
        Regulariser in ``xi_i = w / (sigma_i + eps)``.
    feature_weight : float
        Weight of the guide feature channels in the matching distance
        (0 = off; ignored when no guide is given).  The distance is the
        mean squared colour difference per pixel and
        channel plus ``feature_weight`` times the mean squared guide
        difference per pixel and feature, so with guide channels on the
        image's 0..255 scale, 1 weighs a feature like a colour channel.
    rematch_every : int
        Re-run block matching on the current estimate every this many
        iterations (1 = every iteration, as in Algorithm 1).
    threshold : {"weighted", "constant"}
        PAWNNM weights ``w / (sigma + eps)`` or the constant-threshold NNM ablation.
    data_term : {"exact", "soft"}
        ``"exact"`` re-imposes the rendered samples after each iteration
        (Algorithm 1 step 8), so their Monte Carlo noise stays in the output.
        ``"soft"`` does the same in all but the last iteration and then
        returns ``x_hat + delta * Phi * (M - x_hat)`` with the per-pixel Wiener
        factor ``delta = tau2 / (tau2 + var)``: ``var`` is the variance of the
        sample mean, ``tau2`` the error variance of the low-rank estimate,
        measured from the residual at the rendered pixels (``mean((M -
        x_hat)^2) - mean(var)``).  Softening every iteration instead lets the
        iteration forget the data and over-smooths the missing pixels
        (measured: 1.2 dB worse than this, at 16 iterations without momentum).
        Needs ``variance`` (or ``soft_delta``).
    soft_delta : float or None
        Constant delta for ``data_term="soft"`` when no variance is given.
    noise_power : float
        With a ``variance``, each group's threshold weight is ``w`` times its pixels' mean
        :func:`~gmcpt.lowrank.noise.local_noise_scale` (the traced pixels' variance within
        ``noise_radius``, relative to the frame's, to this power): noisy regions are denoised
        harder, clean ones kept sharper, as WNNM's threshold grows with the noise variance. 0 = one
        weight for the whole frame (the paper).
    noise_radius : int
        Window half side of that local variance.
    wiener : float
        With a ``variance``, after the iterations the estimate is the pilot of a collaborative Wiener pass
        over the rendered samples, on the last iteration's groups (:func:`~gmcpt.lowrank.wiener.group_wiener`),
        whose noise energy this scales; 0 = no pass (the paper).
    momentum : float
        Over-relaxation of the fixed-point iteration, ``x <- x_new + momentum
        * (x_new - x)`` at the missing pixels between iterations (0 =
        Algorithm 1 as printed).  Measured: 0.6-0.85 gain 0.8-0.9 dB at 8-12
        iterations; 1.0 diverges.
    tile_size : int or None
        Reference patches are processed in tiles of this many pixels a side
        (memory grows with the tile, not the frame); None makes one tile (on
        CPU it is still cut into row bands so every thread has work).
    device : str
        Torch device (``"cpu"``, ``"cuda"``), or ``"auto"``: :func:`gmcpt.runtime.device.completion_device`'s
        choice (``$GMCPT_DEVICE``, else CUDA where torch sees a GPU, else the CPU).
    """

    patch_size: int = 7
    step: int = 5
    search_radius: int = 10
    group_size: int = 16
    iterations: int = 11
    w0: float = 1e4
    c: float = 0.9
    eps: float = 1e-8
    feature_weight: float = 0.3
    rematch_every: int = 4
    threshold: str = "weighted"
    data_term: str = "soft"
    soft_delta: float | None = None
    noise_power: float = 0.5
    noise_radius: int = 5
    wiener: float = 2.0
    momentum: float = 0.8
    tile_size: int | None = 128
    device: str = "auto"

    def __post_init__(self):
        ints = dict(patch_size=1, step=1, search_radius=0, group_size=1, iterations=0,
                    rematch_every=1, noise_radius=1)
        for name, low in ints.items():
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {v!r}")
        if self.step > max(1, self.patch_size - 1):
            raise ValueError(f"step must be < patch_size so patches overlap, got {self.step}")
        for name in ("w0", "eps", "feature_weight", "noise_power", "wiener"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
        if not 0 < self.c <= 1:
            raise ValueError(f"c must be in (0, 1], got {self.c!r}")
        if self.threshold not in ("weighted", "constant"):
            raise ValueError(f"threshold must be 'weighted' or 'constant', got {self.threshold!r}")
        if self.data_term not in ("exact", "soft"):
            raise ValueError(f"data_term must be 'exact' or 'soft', got {self.data_term!r}")
        if not 0 <= self.momentum < 1:
            raise ValueError(f"momentum must be in [0, 1), got {self.momentum!r}")
        if self.soft_delta is not None and not 0 <= self.soft_delta <= 1:
            raise ValueError(f"soft_delta must be in [0, 1], got {self.soft_delta!r}")
        if self.tile_size is not None and (not isinstance(self.tile_size, (int, np.integer))
                                           or self.tile_size < 1):
            raise ValueError(f"tile_size must be a positive integer or None, "
                             f"got {self.tile_size!r}")
        if self.device not in ("cpu", "auto"):  # the presets (made when gmcpt is imported) need no torch
            import torch

            try:
                torch.device(self.device)
            except (RuntimeError, TypeError) as err:
                raise ValueError(f"device {self.device!r} is not a torch device") from err


#: The paper's literal settings (w0, c, k; Algorithm 1 re-forms the groups every
#: iteration); patch 7x7, step 3, K = 70 as in the measurement of docs/design.md section 2.
PAPER_PRESET = LowRankParams(patch_size=7, step=3, search_radius=10, group_size=70,
                             iterations=45, w0=80.5, c=0.9, rematch_every=1, feature_weight=0.0,
                             threshold="weighted", data_term="exact", momentum=0.0, noise_power=0.0, wiener=0.0)

#: Tuned default: each setting changed one at a time on synthetic and rendered frames (benchmarks/sweep_lowrank.py,
#: benchmarks/sweep_rendered.py), then thresholds that follow the local noise (``noise_power``) and the
#: collaborative Wiener pass (``wiener``) on the validation split, kept where they gained without costing
#: much time (the figures: docs/experiments.md, "Figures moved out of the code").
DEFAULT = LowRankParams()

#: NNM ablation: constant threshold (w0 is then a singular value, not its square), one for the frame,
#: no Wiener pass: the rule of the paper's Table 2 against PAWNNM's weights and nothing of ours.
NNM_PRESET = replace(DEFAULT, threshold="constant", w0=300.0, noise_power=0.0, wiener=0.0)
