"""Weighted block matching, vectorised over reference patches and offsets.

For a grid of reference patches and every offset ``(dy, dx)`` of a square
search window, the distance between the reference patch at ``p`` and the
candidate at ``p + (dy, dx)`` is

    D = sum_u a(p+u) a(q+u) |x(p+u) - x(q+u)|^2 / (C sum_u a(p+u) a(q+u))
        + feature_weight * sum_u |g(p+u) - g(q+u)|^2 / (F P)

with ``a`` the per-pixel reliability (rendered pixels weigh more than
pre-completed ones), ``x`` the C-channel image and ``g`` optional F guide
channels, so both terms are mean squared differences per pixel and channel.
The per-pixel squared differences are computed for a whole row of offsets at
once on shifted views of the image and box-summed only at the reference
positions; the K nearest candidates are then picked with ``topk``.
"""
from __future__ import annotations

import torch
import torch.nn.functional as F


def _window_sums(t: torch.Tensor, dim: int, starts: list[int], p: int) -> torch.Tensor:
    """Sums of ``p`` consecutive entries of ``t`` along ``dim`` from each start.

    The longest evenly spaced prefix of ``starts`` (a reference grid) is a
    strided ``unfold`` view; the rest (the grid's irregular last position)
    is summed one by one.
    """
    step = starts[1] - starts[0] if len(starts) > 1 else 1
    n = 1
    while n < len(starts) and starts[n] - starts[n - 1] == step:
        n += 1
    parts = [t.narrow(dim, starts[0], (n - 1) * step + p).unfold(dim, p, step).sum(-1)]
    parts += [t.narrow(dim, s0, p).sum(dim, keepdim=True) for s0 in starts[n:]]
    return parts[0] if len(parts) == 1 else torch.cat(parts, dim)


def _box_at(e: torch.Tensor, ry: list[int], rx: list[int], p: int) -> torch.Tensor:
    """Sum ``e`` (h, n, w) over p x p windows with top-left (ry, rx) -> (ny, n, nx)."""
    return _window_sums(_window_sums(e, 0, ry, p), 2, rx, p)


def _sq_dist(ref: torch.Tensor, cand: torch.Tensor) -> torch.Tensor:
    """Channel-summed squared differences, (C, h, w) vs (C, h, n, w) -> (h, n, w)."""
    e = None
    for a, b in zip(ref, cand):
        dd = (a[:, None, :] - b).square_()
        e = dd if e is None else e.add_(dd)
    return e


def block_match(image: torch.Tensor, weight: torch.Tensor, ys: torch.Tensor, xs: torch.Tensor,
                *, patch_size: int, search_radius: int, group_size: int,
                guide: torch.Tensor | None = None, feature_weight: float = 0.0) -> torch.Tensor:
    """Find the most similar patches for a grid of reference patches.

    Parameters
    ----------
    image : torch.Tensor
        ``(C, H, W)`` image (the pre-completed or current estimate).
    weight : torch.Tensor
        ``(H, W)`` positive per-pixel reliability weights.
    ys, xs : torch.Tensor
        Increasing int64 top-left rows / columns of the reference patches;
        the references are the grid ``ys x xs`` in row-major order.
    patch_size : int
        Side of the square patches.
    search_radius : int
        Candidates lie within ``search_radius`` pixels (Chebyshev) of the
        reference, clipped to the image.
    group_size : int
        K, the number of patches per group (reference included); lowered
        for images so small that a corner patch has fewer candidates.
    guide : torch.Tensor, optional
        ``(F, H, W)`` feature channels that join the distance.
    feature_weight : float
        Weight of the guide term; 0 disables it.

    Returns
    -------
    torch.Tensor
        ``(len(ys) * len(xs), K)`` int64 patch indices ``y * (W - p + 1) + x``
        (top-left pixel of each matched patch), nearest first; the reference
        patch itself is always first.
    """
    c, h, w = image.shape
    p, r = patch_size, search_radius
    n = 2 * r + 1
    use_guide = guide is not None and feature_weight > 0
    y0, y1 = int(ys[0]), int(ys[-1]) + p
    x0, x1 = int(xs[0]), int(xs[-1]) + p
    ry, rx = (ys - y0).tolist(), (xs - x0).tolist()

    def pad(t, value):
        return F.pad(t[None], (r, r, r, r), value=value)[0]

    img = pad(image, 0.0)
    wgt = pad(weight[None], 1.0)
    ref = img[:, y0 + r:y1 + r, x0 + r:x1 + r]            # (C, hh, ww)
    ref_w = wgt[:, y0 + r:y1 + r, x0 + r:x1 + r]
    if use_guide:
        gd = pad(guide, 0.0)
        ref_g = gd[:, y0 + r:y1 + r, x0 + r:x1 + r]
    ww = x1 - x0

    dist = []
    for dy in range(-r, r + 1):
        rows = slice(y0 + r + dy, y1 + r + dy)
        cols = slice(x0, x1 + 2 * r)                      # all dx at once via unfold
        aw = ref_w[0, :, None, :] * wgt[0, rows, cols].unfold(1, ww, 1)  # (hh, n, ww)
        e = _sq_dist(ref, img[:, rows, cols].unfold(2, ww, 1)).mul_(aw)
        d = _box_at(e, ry, rx, p) / (c * _box_at(aw, ry, rx, p))
        if use_guide:
            eg = _sq_dist(ref_g, gd[:, rows, cols].unfold(2, ww, 1))
            d = d + (feature_weight / (guide.shape[0] * p * p)) * _box_at(eg, ry, rx, p)
        dist.append(d)                                    # (ny, n(dx), nx)
    dist = torch.stack(dist, 1).permute(0, 3, 1, 2)       # (ny, nx, n(dy), n(dx))

    off = torch.arange(-r, r + 1, device=image.device)
    cy = ys[:, None] + off                                # (ny, n)
    cx = xs[:, None] + off                                # (nx, n)
    bad_y = (cy < 0) | (cy > h - p)
    bad_x = (cx < 0) | (cx > w - p)
    bad = bad_y[:, None, :, None] | bad_x[None, :, None, :]
    dist = dist.masked_fill(bad, float("inf"))
    dist[:, :, r, r] = -1.0                               # the reference always belongs
    flat = dist.reshape(len(ys) * len(xs), n * n)
    # a corner reference has the fewest valid candidates; never pick an invalid one
    k = min(group_size, (min(r, h - p) + 1) * (min(r, w - p) + 1))
    order = torch.topk(flat, k, dim=1, largest=False, sorted=True).indices
    ody, odx = order // n - r, order % n - r
    gy = ys.repeat_interleave(len(xs))[:, None] + ody
    gx = xs.repeat(len(ys))[:, None] + odx
    return gy * (w - p + 1) + gx
