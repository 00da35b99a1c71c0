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
  :data:`~gmcpt.lowrank.params.DEFAULT`).
* ``wiener``: with a per-pixel variance, a last pass Wiener-filters the
  rendered samples, group by group, with the result as the pilot
  (:mod:`gmcpt.lowrank.wiener`; measured on rendered frames, see :data:`~gmcpt.lowrank.params.DEFAULT`).
* Matching distances come from a 5-component projection of colour and
  guide (:func:`~gmcpt.lowrank.matching.matching_signal`), without the
  paper's lower weight for pre-completed pixels (measured: within 0.01 dB).

Tiling only partitions the *reference patches*: each tile matches its
references against the whole current image (candidates may lie in the
neighbouring tiles) and adds its estimates into one global sum, so the result
does not depend on the tile layout beyond float rounding (measured: 1e-4 on
the 0..255 scale).  Results are deterministic on the CPU and on CUDA (the sums there
are added in sorted order: :func:`~gmcpt.lowrank.patches.aggregate`).
"""
from __future__ import annotations

import time

import numpy as np
import torch

from ..runtime.device import completion_device
from ..runtime.workers import map_single_threaded, torch_threads
from .linalg import stable_eigh
from .matching import block_match, matching_signal
from .noise import local_noise_scale
from .params import DEFAULT, LowRankParams
from .patches import aggregate, coverage, gather_groups, pixel_indices, reference_positions
from .wiener import group_wiener

__all__ = ["complete_low_rank", "complete_matrix", "low_rank_estimate"]


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
        As in :class:`~gmcpt.lowrank.params.LowRankParams`.

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
    dealt round-robin to that many threads (:func:`gmcpt.runtime.workers.map_single_threaded`),
    each running torch single-threaded: coarse tasks instead of OpenMP/MKL parallel
    regions per small op, which cost more than they gain on the small batched
    matrices here and stall badly when the machine is busy.  Partial results are
    reduced in share order, so the output does not depend on scheduling.
    """

    def __init__(self, device: torch.device):
        self.n = torch.get_num_threads() if device.type == "cpu" else 1
        self.shares = [()] * self.n

    def deal(self, n_tiles: int):
        """Split tiles ``0..n_tiles-1`` round-robin over the workers."""
        self.n = min(self.n, n_tiles)
        self.shares = [tuple(range(j, n_tiles, self.n)) for j in range(self.n)]

    def __call__(self, fn):
        if self.n == 1:
            return [fn(self.shares[0])]
        return map_single_threaded(fn, self.shares, self.n)


#: Groups thresholded or filtered at a time: their group matrices (about 2 MB) stay small enough for the
#: allocator to reuse (1024x1024 frame, gan_pawnnm: Wiener pass 0.79 s instead of 1.10 with a tile's groups
#: at once, thresholds 0.83 instead of 0.92).
GROUP_CHUNK = 256


def _chunks(tile_groups):
    """The groups of some tiles, in chunks of at most :data:`GROUP_CHUNK`."""
    for groups in tile_groups:
        yield from groups.split(GROUP_CHUNK)


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
        Settings; see :data:`~gmcpt.lowrank.params.DEFAULT` and :data:`~gmcpt.lowrank.params.PAPER_PRESET`.

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
    dev = torch.device(completion_device(params.device))
    f32 = dict(dtype=torch.float32, device=dev)

    x = torch.as_tensor(pre.reshape(-1, ch), **f32)
    phi = torch.as_tensor(mask.reshape(-1), device=dev)
    m = torch.as_tensor(np.where(mask[..., None], obs, 0.0).reshape(-1, ch), **f32)
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

    def match(share, signal):
        t0 = time.perf_counter()
        grps = [block_match(signal, tiles[i][0], tiles[i][1], patch_size=p,
                            search_radius=params.search_radius, group_size=params.group_size) for i in share]
        cov = torch.zeros(h * w, **f32)
        for grp in grps:
            cov += coverage(pixel_indices(grp, w, p), h * w)
        return grps, cov, time.perf_counter() - t0

    def regroup():
        """Block-match the current estimate: (groups by share, coverage of every pixel)."""
        t0 = time.perf_counter()
        signal = matching_signal(x.T.reshape(ch, h, w), g, params.feature_weight)
        res = run(lambda share: match(share, signal))
        timing["block_matching_s"] += time.perf_counter() - t0
        return dict(zip(run.shares, (r[0] for r in res))), sum(r[1] for r in res)

    def estimate(share):
        t_svd = t_agg = 0.0
        num = torch.zeros(h * w, ch, **f32)
        for grp in _chunks(groups[share]):
            t0 = time.perf_counter()
            pix = pixel_indices(grp, w, p)
            weight = wt if scale is None else wt * scale[pix].mean((1, 2))[:, None]
            est = low_rank_estimate(gather_groups(x, pix), weight, eps=params.eps,
                                    threshold=params.threshold)
            t1 = time.perf_counter()
            aggregate(est, pix, num)
            t_svd, t_agg = t_svd + t1 - t0, t_agg + time.perf_counter() - t1
        return num, t_svd, t_agg

    def wiener(share):
        num = torch.zeros(h * w, ch, **f32)
        for grp in _chunks(groups[share]):
            pix = pixel_indices(grp, w, p)
            est = group_wiener(gather_groups(x, pix), gather_groups(noisy, pix), noise[pix], params.wiener)
            aggregate(est, pix, num)
        return num

    def average(num):
        """The aggregated patch estimates as an image; pixels no group covers keep the current value."""
        return torch.where((den > 0)[:, None], num / den.clamp_min(1.0)[:, None], x)

    # this thread runs torch on one thread too: idle OpenMP threads of its own spin after each
    # operation and take the cores from the workers (256x256: SVD and Wiener stages about 10% slower)
    with torch_threads(1 if run.n > 1 else torch.get_num_threads()):
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
            noisy = torch.where(phi[:, None], m, x)
            noise = torch.as_tensor(rendered_variance.reshape(-1), **f32)
            x = average(sum(run(wiener)))
            timing["wiener_s"] = time.perf_counter() - t0

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
