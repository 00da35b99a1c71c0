"""Block matching on a matching signal, vectorised over reference patches and offsets.

The distance between the patch at ``p`` and the candidate at ``q`` is the sum
over the patch's pixels ``u`` of ``|z(p+u) - z(q+u)|^2``, where the matching
signal ``z`` (:func:`matching_signal`) stacks the image's channels and the
guide features, each scaled so the sum is the mean squared colour difference
per channel plus ``feature_weight`` times the mean squared feature difference
per feature (times the patch's pixel count), projected on the leading
principal components of the stacked channels.

Expanded, ``|a - b|^2 = |a|^2 + |b|^2 - 2 a.b``: the reference's own energy
does not change which candidates are nearest, the candidates' energies are
one box filter of ``|z|^2``, and only the cross term depends on the offset.
For a whole row of offsets at once the cross term is summed on shifted views
of the signal and box-summed only at the reference positions; the K nearest
candidates are then picked with ``topk``.
"""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F

#: Principal components of the stacked colour and guide channels that the matching keeps. Measured on
#: the 5 evaluation scenes (``gan_pawnnm``, rates 0.2/0.3/0.4): all 10 channels and 5 or 6 components
#: score within 0.01 dB of each other; 4 components lose 0.01-0.04 dB, 3 lose 0.03-0.07.
COMPONENTS = 5


def matching_signal(image: torch.Tensor, guide: torch.Tensor | None = None, feature_weight: float = 0.0,
                    components: int | None = COMPONENTS) -> torch.Tensor:
    """The ``(M, H, W)`` signal whose squared patch differences are the matching distance.

    Parameters
    ----------
    image : torch.Tensor
        ``(C, H, W)`` image (the pre-completed or current estimate).
    guide : torch.Tensor, optional
        ``(F, H, W)`` feature channels that join the distance.
    feature_weight : float
        Weight of the guide term; 0 leaves the guide out.
    components : int or None
        Keep this many principal components of the stacked, centred channels
        (None: all of them).

    Returns
    -------
    torch.Tensor
        Contiguous float signal, ``M = min(components, C + F)``.
    """
    parts = [image / math.sqrt(image.shape[0])]
    if guide is not None and feature_weight > 0:
        parts.append(guide * math.sqrt(feature_weight / guide.shape[0]))
    signal = torch.cat(parts)
    signal = signal - signal.mean((1, 2), keepdim=True)  # small magnitudes keep the expanded distance exact
    channels = signal.shape[0]
    if components is None or components >= channels:
        return signal.contiguous()
    flat = signal.reshape(channels, -1)
    _, vectors = torch.linalg.eigh((flat @ flat.T).double())   # ascending eigenvalues
    basis = vectors[:, -components:].to(signal.dtype)
    return (basis.T @ flat).reshape(components, *signal.shape[1:]).contiguous()


def _box_sums(t: torch.Tensor, starts: list[int], p: int) -> torch.Tensor:
    """Sums of ``p`` consecutive entries of ``t`` along dim 0 from each start.

    The longest evenly spaced prefix of ``starts`` (a reference grid) is ``p``
    strided slices added together; the rest (the grid's irregular last
    position) is summed one by one.
    """
    step = starts[1] - starts[0] if len(starts) > 1 else 1
    n = 1
    while n < len(starts) and starts[n] - starts[n - 1] == step:
        n += 1
    first, span = starts[0], (n - 1) * step + 1
    out = t[first:first + span:step].clone()
    for i in range(1, p):
        out += t[first + i:first + i + span:step]
    if n == len(starts):
        return out
    return torch.cat([out, torch.stack([t[s:s + p].sum(0) for s in starts[n:]])])


def block_match(signal: torch.Tensor, ys: torch.Tensor, xs: torch.Tensor, *, patch_size: int,
                search_radius: int, group_size: int) -> torch.Tensor:
    """Find the most similar patches for a grid of reference patches.

    Parameters
    ----------
    signal : torch.Tensor
        ``(M, H, W)`` matching signal (:func:`matching_signal`).
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

    Returns
    -------
    torch.Tensor
        ``(len(ys) * len(xs), K)`` int64 patch indices ``y * (W - p + 1) + x``
        (top-left pixel of each matched patch), nearest first; the reference
        patch itself is always first.
    """
    _, h, w = signal.shape
    p, r = patch_size, search_radius
    n = 2 * r + 1
    y0, y1 = int(ys[0]), int(ys[-1]) + p
    x0, x1 = int(xs[0]), int(xs[-1]) + p
    hh, ww = y1 - y0, x1 - x0
    ry, rx = (ys - y0).tolist(), (xs - x0).tolist()
    # the window the references and their candidates lie in, padded where it leaves the frame:
    # window[:, i, j] is the signal at (y0 - r + i, x0 - r + j)
    top, left, bottom, right = max(0, r - y0), max(0, r - x0), max(0, y1 + r - h), max(0, x1 + r - w)
    window = F.pad(signal[None, :, y0 - r + top:y1 + r - bottom, x0 - r + left:x1 + r - right],
                   (left, right, top, bottom))[0]
    ref = window[:, r:r + hh, r:r + ww]                             # (M, hh, ww)
    # |z|^2 of every candidate patch, indexed by its top-left pixel in window coordinates
    energy = F.avg_pool2d(window.square().sum(0)[None, None], p, stride=1)[0, 0] * (p * p)
    offsets = torch.arange(-r, r + 1, device=signal.device)
    local_ys = ys - y0 + r
    columns = (xs[None, :] - x0 + offsets[:, None] + r).reshape(1, -1).expand(len(ys), -1)   # (ny, n * nx)

    dist = []
    # one buffer for every row of offsets: a fresh tensor of this size a row costs five times the arithmetic
    # (the allocator maps and faults in new pages each time)
    cross = torch.empty((hh, n, ww), dtype=signal.dtype, device=signal.device)
    for dy in range(-r, r + 1):
        candidates = window[:, r + dy:r + dy + hh].unfold(2, ww, 1)   # (M, hh, n(dx), ww)
        torch.mul(ref[0, :, None, :], candidates[0], out=cross)
        for a, b in zip(ref[1:], candidates[1:]):
            cross.addcmul_(a[:, None, :], b)
        sums = _box_sums(_box_sums(cross, ry, p).permute(2, 0, 1), rx, p).permute(1, 2, 0)   # (ny, n, nx)
        candidate_energy = torch.gather(energy[local_ys + dy], 1, columns).reshape(len(ys), n, len(xs))
        dist.append(candidate_energy.sub_(sums.mul_(2)))
    dist = torch.stack(dist, 1).permute(0, 3, 1, 2)                # (ny, nx, n(dy), n(dx))

    cy = ys[:, None] + offsets                                     # (ny, n)
    cx = xs[:, None] + offsets                                     # (nx, n)
    bad = ((cy < 0) | (cy > h - p))[:, None, :, None] | ((cx < 0) | (cx > w - p))[None, :, None, :]
    dist = dist.masked_fill(bad, float("inf"))
    dist[:, :, r, r] = -float("inf")                               # the reference always belongs
    flat = dist.reshape(len(ys) * len(xs), n * n)
    # a corner reference has the fewest valid candidates; never pick an invalid one
    k = min(group_size, (min(r, h - p) + 1) * (min(r, w - p) + 1))
    order = torch.topk(flat, k, dim=1, largest=False, sorted=True).indices
    ody, odx = order // n - r, order % n - r
    gy = ys.repeat_interleave(len(xs))[:, None] + ody
    gx = xs.repeat(len(ys))[:, None] + odx
    return gy * (w - p + 1) + gx
