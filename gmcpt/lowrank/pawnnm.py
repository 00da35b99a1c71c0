"""PAWNNM: patch-group low-rank completion with a shrinking weighted threshold.

Paper section III-C and Algorithm 1, as read in docs/design.md section 4.  Each
iteration (re-)groups similar patches of the current estimate, replaces every
d x K group matrix X by its weighted singular value thresholding

    X_hat = U max(S - xi, 0) V^T + mean,   xi_i = w / (sigma_i + eps)

(``threshold="constant"``: xi_i = w, the NNM ablation, same code path),
averages the overlapping patch estimates back into an image (plain mean),
applies the data term and shrinks the weight, ``w <- c w``.

Choices beyond the paper, each measured on the synthetic benchmark
(``benchmarks/sweep_lowrank.py``; 256x256, 30 % samples, noise std 12 on the
0..255 scale, Gaussian-fill pre-completion at 24.2 dB):

* Speed.  All groups of a tile are one float32 batch; the SVD comes from
  ``eigh`` of the K x K Gram matrix (``X_hat = X V diag(shrink(s)/s) V^T``);
  blocks are re-matched every ``rematch_every`` iterations only.  On CPU the
  tiles are dealt to ``torch.get_num_threads()`` Python threads that each run
  torch single-threaded (see :class:`_Workers`).
* Reference grid step 5 for 7x7 patches (patches overlap by two pixels, as the
  paper's section IV-C says) instead of step < p/2: PSNR within 0.1 dB of
  step 3 or 4 at 40-60 % of the cost.
* ``momentum``: over-relaxation of the missing pixels between iterations,
  +0.9 dB at equal cost.
* ``data_term="soft"``: the last iteration blends the samples with the
  low-rank estimate by their variance instead of re-imposing them, +2.0 dB
  (re-imposed Monte Carlo noise caps the exact variant).
* ``noise_power``: with a per-pixel variance, each group's threshold weight
  follows the local noise level (measured on rendered frames, see
  :data:`DEFAULT`).
* ``wiener``: with a per-pixel variance, a last pass Wiener-filters the
  rendered samples, group by group, with the result as the pilot
  (:mod:`gmcpt.lowrank.wiener`; measured on rendered frames, see :data:`DEFAULT`).

Tiling only partitions the *reference patches*: each tile matches its
references against the whole current image (candidates may lie in the
neighbouring tiles) and adds its estimates into one global sum, so the result
does not depend on the tile layout beyond float rounding (measured: 1e-4 on
the 0..255 scale).  Results are deterministic on CPU; on CUDA ``index_add_``
sums in arbitrary order, so repeated runs differ by float rounding.
"""
from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
import torch

from .linalg import stable_eigh
from .matching import block_match
from .noise import local_noise_scale
from .patches import aggregate, coverage, gather_groups, pixel_indices, reference_positions
from .wiener import group_wiener

__all__ = ["LowRankParams", "PAPER_PRESET", "DEFAULT", "NNM_PRESET", "complete_low_rank",
           "complete_matrix", "low_rank_estimate"]


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
    rendered_weight, filled_weight : float
        Reliability of rendered / pre-completed pixels in the block-matching
        distance (only their ratio matters).
    feature_weight : float
        Weight of the guide feature channels in the matching distance
        (0 = off; ignored when no guide is given).  The distance is the
        reliability-weighted mean squared colour difference per pixel and
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
        Torch device, e.g. ``"cpu"`` or ``"cuda"``.
    """

    patch_size: int = 7
    step: int = 5
    search_radius: int = 10
    group_size: int = 16
    iterations: int = 11
    w0: float = 1e4
    c: float = 0.9
    eps: float = 1e-8
    rendered_weight: float = 1.0
    filled_weight: float = 0.5
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
    device: str = "cpu"

    def __post_init__(self):
        ints = dict(patch_size=1, step=1, search_radius=0, group_size=1, iterations=0,
                    rematch_every=1, noise_radius=1)
        for name, low in ints.items():
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or v < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {v!r}")
        if self.step > max(1, self.patch_size - 1):
            raise ValueError(f"step must be < patch_size so patches overlap, got {self.step}")
        for name in ("w0", "eps", "rendered_weight", "filled_weight", "feature_weight", "noise_power", "wiener"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
        if self.rendered_weight <= 0 or self.filled_weight <= 0:
            raise ValueError("rendered_weight and filled_weight must be > 0")
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
        try:
            torch.device(self.device)
        except (RuntimeError, TypeError) as err:
            raise ValueError(f"device {self.device!r} is not a torch device") from err


#: The paper's literal settings (w0, c, k; Algorithm 1 re-forms the groups every
#: iteration); patch 7x7, step 3, K = 70 as in the measurement of docs/design.md section 2.
PAPER_PRESET = LowRankParams(patch_size=7, step=3, search_radius=10, group_size=70,
                             iterations=45, w0=80.5, c=0.9, rematch_every=1, feature_weight=0.0,
                             threshold="weighted", data_term="exact", momentum=0.0, noise_power=0.0, wiener=0.0)

#: Tuned default. First from benchmarks/sweep_lowrank.py on two synthetic
#: 256x256 frames (30 % samples, noise std 12): patch 7, step 5, K 16, 11
#: iterations, c 0.9, momentum 0.8, soft data term, re-matching every 4
#: iterations (one change at a time, dB: K 24 +0.2 at 1.7x time, 15 iterations
#: +0.3 at 1.3x, step 3 +0.1 at 2.7x, c = 1 -0.7, no momentum -0.9, exact data
#: term -2.0). Then from benchmarks/sweep_rendered.py on the rendered frames of
#: cornell-box and still-life (256x256, 16 spp, rates 0.2/0.3/0.4, seed 0),
#: scored by the worst frame's tonemapped-PSNR gain over interp: w0 3e4 -> 1e4,
#: search radius 8 -> 10, feature weight 0 -> 0.3 together +0.4 dB (worst frame
#: +2.3 -> +2.8), and the low-rank domain's albedo_eps 0.02 -> 0.2 another +0.9
#: (worst frame +3.6; see gmcpt.completion.matrix.LOW_RANK_DOMAIN). Tried and
#: left: K 24 (-2.6 dB on cornell-box at rate 0.2), c 0.8, momentum 0.6,
#: patch 5 or 8, 16 iterations, two passes.
DEFAULT = LowRankParams()

#: Then (2026-11-23) ``noise_power`` 0 -> 0.5, thresholds that follow the local noise: ``pawnnm`` on the
#: dataset's validation split 29.61 -> 29.77 dB, on the 5 evaluation scenes (rendered, rates
#: 0.2/0.3/0.4) 32.65/33.30/33.93 -> 32.77/33.57/34.22 (power 1: 32.76/33.60/34.25, the breakfast room
#: -0.2 dB).
#: Then (2026-11-23) ``wiener`` 0 -> 2, the collaborative Wiener pass: ``pawnnm`` on the validation split
#: 29.77 -> 30.41 dB, ``gan_pawnnm`` 31.50 -> 31.59 (before the mean patch's own factor, with re-matched
#: groups: on a step-3 grid, noise scale 1: 30.33 and 31.58, 2: 30.46 and 31.57, 4: 30.51 and 31.52; on
#: the step-5 grid ``pawnnm`` 2: 30.41, 4: 30.46, 8: 30.43, ``gan_pawnnm`` 1: 31.59, 2: 31.57, 4: 31.52);
#: on the 5 evaluation scenes 32.77/33.57/34.22 -> 32.84/33.74/34.57 and
#: 33.97/34.51/35.00 -> 34.06/34.62/35.06, for +0.1 s on a 256x256 frame. The pass reuses the last
#: iteration's groups: re-matching on the result scored the same on validation for +0.25 s. On a
#: reference grid of step 3 instead of 5: +0.04 dB for twice the time; 32 patches a group: +0.1 dB for
#: four times.

#: NNM ablation: constant threshold (w0 is then a singular value, not its square), one for the frame,
#: no Wiener pass: the rule of the paper's Table 2 against PAWNNM's weights and nothing of ours.
NNM_PRESET = replace(DEFAULT, threshold="constant", w0=300.0, noise_power=0.0, wiener=0.0)


def _shrink_factor(s: torch.Tensor, w: float, eps: float, threshold: str) -> torch.Tensor:
    """Per-singular-value factor ``max(s - xi, 0) / s`` (0 where s == 0)."""
    xi = w / (s + eps) if threshold == "weighted" else w * torch.ones_like(s)
    shrunk = torch.clamp(s - xi, min=0.0)
    return torch.where(s > 0, shrunk / s.clamp_min(torch.finfo(s.dtype).tiny), 0.0)


def low_rank_estimate(groups: torch.Tensor, w: float | torch.Tensor, *, eps: float = 1e-8,
                      threshold: str = "weighted") -> torch.Tensor:
    """Weighted singular value thresholding of a batch of group matrices.

    Parameters
    ----------
    groups : torch.Tensor
        ``(G, K, d)``: G transposed group matrices (row k = patch k).
    w : float or torch.Tensor
        Threshold weight, or one per group, shape ``(G, 1)``.
    eps : float
        Regulariser of the weighted threshold.
    threshold : {"weighted", "constant"}
        ``xi_i = w / (sigma_i + eps)`` or ``xi_i = w``.

    Returns
    -------
    torch.Tensor
        ``(G, K, d)`` estimates: the group mean (over the K patches) is removed,
        the singular values shrunk, the matrix rebuilt and the mean put back.
        The singular vectors come from ``eigh`` of the smaller Gram matrix.
    """
    mean = groups.mean(1, keepdim=True)
    y = groups - mean
    k, d = y.shape[1:]
    if k <= d:   # X^T X = V S^2 V^T  ->  X_hat^T = V f(S) V^T X^T
        lam, v = stable_eigh(y @ y.mT)                        # (G, K, K)
        f = _shrink_factor(lam.clamp_min(0).sqrt(), w, eps, threshold)
        est = ((v * f[:, None, :]) @ v.mT) @ y
    else:        # X X^T = U S^2 U^T  ->  X_hat^T = X^T U f(S) U^T
        lam, u = stable_eigh(y.mT @ y)                        # (G, d, d)
        f = _shrink_factor(lam.clamp_min(0).sqrt(), w, eps, threshold)
        est = y @ ((u * f[:, None, :]) @ u.mT)
    return est.add_(mean)


def complete_matrix(matrix, observed, *, w0: float, c: float = 0.9, iterations: int = 100,
                    eps: float = 1e-8, threshold: str = "weighted") -> np.ndarray:
    """Complete one matrix with the PAWNNM iteration (exact data term).

    The same update as :func:`complete_low_rank` on a single group:
    ``X <- P_obs(M) + P_miss(D_w(X))``, ``w <- c w``, where ``D_w`` is
    :func:`low_rank_estimate` (mean over columns removed and restored).

    Parameters
    ----------
    matrix : array_like
        ``(d, K)`` matrix; only entries where ``observed`` is True are used.
    observed : array_like of bool
        ``(d, K)`` mask of known entries.
    w0, c, iterations, eps, threshold
        As in :class:`LowRankParams`.

    Returns
    -------
    numpy.ndarray
        The completed ``(d, K)`` float64 matrix.
    """
    m = np.asarray(matrix, dtype=np.float64)
    obs = np.asarray(observed, dtype=bool)
    if m.ndim != 2 or obs.shape != m.shape:
        raise ValueError(f"matrix and observed must be equal-shaped 2-D arrays, "
                         f"got {m.shape} and {obs.shape}")
    if not obs.any() or not np.isfinite(m[obs]).all():
        raise ValueError("observed entries must exist and be finite")
    mt = torch.from_numpy(np.where(obs, m, 0.0).T.copy())[None]   # (1, K, d)
    ob = torch.from_numpy(obs.T.copy())[None]
    x = torch.where(ob, mt, mt[ob].mean())
    w = float(w0)
    n = torch.get_num_threads()
    torch.set_num_threads(1)        # one small matrix: threads only add synchronisation
    try:
        for _ in range(iterations):
            x = torch.where(ob, mt, low_rank_estimate(x, w, eps=eps, threshold=threshold))
            w *= c
    finally:
        torch.set_num_threads(n)
    return x[0].T.numpy()


def _validate(pre, obs, mask, variance, guide, params):
    pre = np.asarray(pre)
    squeeze = pre.ndim == 2
    if squeeze:
        pre = pre[..., None]
    if pre.ndim != 3:
        raise ValueError(f"pre_completed must be (H, W, C) or (H, W), got shape {pre.shape}")
    h, w, _ = pre.shape
    obs = np.asarray(obs)
    if squeeze and obs.ndim == 2:
        obs = obs[..., None]
    if obs.shape != pre.shape:
        raise ValueError(f"observed shape {obs.shape} does not match pre_completed {pre.shape}")
    mask = np.asarray(mask)
    if mask.shape != (h, w):
        raise ValueError(f"mask must be (H, W) = {(h, w)}, got {mask.shape}")
    if mask.dtype != bool:
        if not np.isin(mask, (0, 1)).all():
            raise ValueError("mask must be boolean (or 0/1)")
        mask = mask.astype(bool)
    p = params.patch_size
    if h < p or w < p:
        raise ValueError(f"image {h}x{w} is smaller than the {p}x{p} patch")
    if not np.isfinite(pre).all():
        raise ValueError("pre_completed contains NaN or inf")
    if not np.isfinite(obs[mask]).all():
        raise ValueError("observed contains NaN or inf at rendered pixels")
    if variance is not None:
        variance = np.asarray(variance)
        if variance.shape != (h, w):
            raise ValueError(f"variance must be (H, W) = {(h, w)}, got {variance.shape}")
        if not (np.isfinite(variance[mask]).all() and (variance[mask] >= 0).all()):
            raise ValueError("variance must be finite and >= 0 at rendered pixels")
    elif params.data_term == "soft" and params.soft_delta is None:
        raise ValueError("data_term='soft' needs a variance (or params.soft_delta)")
    if guide is not None:
        guide = np.asarray(guide)
        if guide.ndim == 2:
            guide = guide[..., None]
        if guide.ndim != 3 or guide.shape[:2] != (h, w):
            raise ValueError(f"guide must be (H, W, F) with H, W = {(h, w)}, got {guide.shape}")
        if not np.isfinite(guide).all():
            raise ValueError("guide contains NaN or inf")
    return pre, obs, mask, variance, guide, squeeze


class _Workers:
    """Run a function over a fixed split of the tiles, one share per worker.

    On CPU with ``torch.get_num_threads() > 1`` and several tiles, tiles are
    dealt round-robin to that many Python threads, each running torch
    single-threaded: coarse tasks instead of OpenMP/MKL parallel regions per
    small op, which cost more than they gain on the small batched matrices
    here and stall badly when the machine is busy.  Shares are fixed and
    partial results are reduced in share order, so the output does not depend
    on scheduling.  The caller's thread setting is restored by :meth:`close`.
    """

    def __init__(self, device: torch.device):
        self.threads = torch.get_num_threads()
        self.n = self.threads if device.type == "cpu" else 1
        self.shares = [()] * self.n
        self.pool = None

    def deal(self, n_tiles: int):
        """Split tiles ``0..n_tiles-1`` round-robin over the workers."""
        self.n = min(self.n, n_tiles)
        self.shares = [tuple(range(j, n_tiles, self.n)) for j in range(self.n)]
        if self.n > 1:
            self.pool = ThreadPoolExecutor(self.n)

    def __call__(self, fn):
        if self.pool is None:
            return [fn(self.shares[0])]

        def task(share):
            torch.set_num_threads(1)
            return fn(share)

        torch.set_num_threads(1)
        return list(self.pool.map(task, self.shares))

    def close(self):
        if self.pool is not None:
            self.pool.shutdown()
            torch.set_num_threads(self.threads)


def _tiles(positions: torch.Tensor, tile_size: int | None, size: int):
    if tile_size is None or tile_size >= size:
        return [positions]
    key = positions // tile_size
    return [positions[key == t] for t in torch.unique(key)]


def complete_low_rank(pre_completed, observed, mask, *, variance=None, guide=None,
                      params: LowRankParams = DEFAULT):
    """Refine a pre-completed image by patch-group low-rank completion (PAWNNM).

    Parameters
    ----------
    pre_completed : array_like
        ``(H, W, C)`` (or ``(H, W)``) image in the working domain, every pixel
        filled (e.g. the GAN output).
    observed : array_like
        Same shape: rendered samples in the working domain; read only where
        ``mask`` is True (may hold anything, even NaN, elsewhere).
    mask : array_like of bool
        ``(H, W)``, True where a pixel was rendered.
    variance : array_like, optional
        ``(H, W)`` variance of the sample mean in the working domain, used
        by ``data_term="soft"`` and to scale the thresholds (``params.noise_power``).
    guide : array_like, optional
        ``(H, W, F)`` feature channels (albedo, normal, depth, ...) on a
        range comparable to the image (0..255-like), used in block matching
        when ``params.feature_weight > 0``.
    params : LowRankParams
        Settings; see :data:`DEFAULT` and :data:`PAPER_PRESET`.

    Returns
    -------
    image : numpy.ndarray
        The completed image, float32, same shape as ``pre_completed``.
    timings : dict of str to float
        Seconds spent in ``block_matching_s``, ``svd_s`` (gathering groups and
        thresholding), ``aggregation_s`` (averaging and data term) and ``wiener_s``
        (the Wiener pass's filtering and averaging), and ``total_s``.
    """
    t_start = time.perf_counter()
    pre, obs, mask, variance, guide, squeeze = _validate(
        pre_completed, observed, mask, variance, guide, params)
    h, w, ch = pre.shape
    p = params.patch_size
    dev = torch.device(params.device)
    f32 = dict(dtype=torch.float32, device=dev)

    x = torch.as_tensor(pre.reshape(-1, ch), **f32)
    phi = torch.as_tensor(mask.reshape(-1), device=dev)
    m = torch.as_tensor(np.where(mask[..., None], obs, 0.0).reshape(-1, ch), **f32)
    rel = torch.where(torch.as_tensor(mask, device=dev),
                      params.rendered_weight, params.filled_weight).to(**f32)
    use_guide = guide is not None and params.feature_weight > 0
    g = torch.as_tensor(np.moveaxis(guide, -1, 0), **f32) if use_guide else None
    rendered_variance = None if variance is None else np.where(mask, variance, 0.0)
    var = scale = None
    if params.data_term == "soft" and variance is not None:
        var = torch.as_tensor(rendered_variance.reshape(-1), **f32)
    if variance is not None and params.noise_power > 0:
        scale = torch.as_tensor(local_noise_scale(rendered_variance, mask, params.noise_radius,
                                                  params.noise_power).reshape(-1), **f32)

    ys = reference_positions(h, p, params.step).to(dev)
    xs = reference_positions(w, p, params.step).to(dev)
    tiles = [(ty, tx) for ty in _tiles(ys, params.tile_size, h)
             for tx in _tiles(xs, params.tile_size, w)]
    run = _Workers(dev)
    while len(tiles) < len(run.shares) and any(len(ty) > 1 for ty, _ in tiles):
        tiles = [(part, tx) for ty, tx in tiles for part in ty.tensor_split(2) if len(part)]
    run.deal(len(tiles))
    timing = dict(block_matching_s=0.0, svd_s=0.0, aggregation_s=0.0, wiener_s=0.0)
    groups, den = None, None
    wt = float(params.w0)

    def match(share):
        t0 = time.perf_counter()
        img = x.T.reshape(ch, h, w)
        grps = [block_match(img, rel, tiles[i][0], tiles[i][1], patch_size=p,
                            search_radius=params.search_radius, group_size=params.group_size,
                            guide=g, feature_weight=params.feature_weight) for i in share]
        cov = torch.zeros(h * w, **f32)
        for grp in grps:
            cov += coverage(pixel_indices(grp, w, p), h * w)
        return grps, cov, time.perf_counter() - t0

    def regroup():
        """Block-match the current estimate: (groups by share, coverage of every pixel)."""
        t0 = time.perf_counter()
        res = run(match)
        timing["block_matching_s"] += time.perf_counter() - t0
        return dict(zip(run.shares, (r[0] for r in res))), sum(r[1] for r in res)

    def estimate(share):
        t_svd = t_agg = 0.0
        num = torch.zeros(h * w, ch, **f32)
        img = x.reshape(h, w, ch)
        for grp in groups[share]:
            t0 = time.perf_counter()
            pix = pixel_indices(grp, w, p)
            weight = wt if scale is None else wt * scale[pix].mean((1, 2))[:, None]
            est = low_rank_estimate(gather_groups(img, grp, p), weight, eps=params.eps,
                                    threshold=params.threshold)
            t1 = time.perf_counter()
            aggregate(est, pix, num)
            t_svd, t_agg = t_svd + t1 - t0, t_agg + time.perf_counter() - t1
        return num, t_svd, t_agg

    def wiener(share):
        num = torch.zeros(h * w, ch, **f32)
        pilot = x.reshape(h, w, ch)
        for grp in groups[share]:
            est = group_wiener(gather_groups(pilot, grp, p), gather_groups(noisy, grp, p),
                               gather_groups(noise, grp, p), params.wiener)
            aggregate(est, pixel_indices(grp, w, p), num)
        return num

    def average(num):
        """The aggregated patch estimates as an image; pixels no group covers keep the current value."""
        return torch.where((den > 0)[:, None], num / den.clamp_min(1.0)[:, None], x)

    try:
        for it in range(params.iterations):
            if it % params.rematch_every == 0:
                groups, den = regroup()

            t0 = time.perf_counter()
            res = run(estimate)
            num = sum(r[0] for r in res)
            wall = time.perf_counter() - t0
            busy = sum(r[1] + r[2] for r in res) or 1.0
            timing["svd_s"] += wall * sum(r[1] for r in res) / busy
            timing["aggregation_s"] += wall * sum(r[2] for r in res) / busy

            t0 = time.perf_counter()
            x_hat = average(num)
            x_new = _data_term(x_hat, m, phi, var, params, last=it == params.iterations - 1)
            if params.momentum and it < params.iterations - 1:
                x_new = torch.where(phi[:, None], x_new, x_new + params.momentum * (x_new - x))
            x = x_new
            wt *= params.c
            timing["aggregation_s"] += time.perf_counter() - t0

        if params.wiener > 0 and variance is not None:
            if groups is None:   # no iterations: group the pre-completion
                groups, den = regroup()
            t0 = time.perf_counter()
            noisy = torch.where(phi[:, None], m, x).reshape(h, w, ch)
            noise = torch.as_tensor(rendered_variance, **f32)[..., None].expand(h, w, ch)
            x = average(sum(run(wiener)))
            timing["wiener_s"] = time.perf_counter() - t0
    finally:
        run.close()

    out = x.reshape(h, w, ch).cpu().numpy().astype(np.float32)
    timing["total_s"] = time.perf_counter() - t_start
    return (out[..., 0] if squeeze else out), timing


def _data_term(x_hat, m, phi, var, params, last=False):
    """Re-impose the samples; with ``data_term="soft"`` blend them at the last iteration."""
    if params.data_term == "exact" or not last:
        return torch.where(phi[:, None], m, x_hat)
    if var is None:
        delta = torch.full_like(phi, params.soft_delta, dtype=x_hat.dtype)
    else:
        resid2 = ((m - x_hat)[phi] ** 2).mean()
        vmean = var[phi].mean()
        tau2 = torch.clamp(resid2 - vmean, min=1e-3 * vmean + 1e-12)
        delta = tau2 / (tau2 + var)
    return x_hat + (delta * phi)[:, None] * (m - x_hat)
