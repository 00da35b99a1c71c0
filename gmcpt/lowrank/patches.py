"""Patch geometry: reference grids, group matrices, aggregation.

A patch is named by the flat index ``y * (W - p + 1) + x`` of its top-left
pixel among all ``(H - p + 1) * (W - p + 1)`` patch positions, so G groups of
K patches are an int64 tensor of shape ``(G, K)``.  Images are flat
``(H*W, C)`` tensors; a patch vector is its pixels in row-major order, channels last
(``d = p * p * C`` entries).
"""
from __future__ import annotations

import torch


def reference_positions(size: int, patch_size: int, step: int) -> torch.Tensor:
    """Top-left coordinates of the reference patches along one axis.

    Parameters
    ----------
    size : int
        Image extent along the axis, ``>= patch_size``.
    patch_size : int
        Patch extent.
    step : int
        Stride between reference patches.

    Returns
    -------
    torch.Tensor
        Increasing int64 positions ``0, step, 2*step, ...`` with the last
        position ``size - patch_size`` always included, so every pixel is
        covered by at least one reference patch.
    """
    last = size - patch_size
    pos = list(range(0, last + 1, step))
    if pos[-1] != last:
        pos.append(last)
    return torch.tensor(pos, dtype=torch.int64)


def gather_groups(image: torch.Tensor, pix: torch.Tensor) -> torch.Tensor:
    """Group matrices ``(G, K, d)`` of a flat ``(H*W, C)`` image at the ``(G, K, p*p)`` pixel indices of
    :func:`pixel_indices`; row k of group g is patch k (the transpose of the paper's d x K matrix),
    ``d = p * p * C``."""
    return image.index_select(0, pix.reshape(-1)).reshape(*pix.shape[:2], -1)


def pixel_indices(groups: torch.Tensor, width: int, patch_size: int) -> torch.Tensor:
    """Flat pixel indices ``y * W + x`` of every pixel of every grouped patch, ``(G, K, p*p)``."""
    p = patch_size
    wp = width - p + 1
    r = torch.arange(p, device=groups.device)
    offsets = (r[:, None] * width + r[None, :]).reshape(-1)
    top_left = (groups // wp) * width + groups % wp
    return top_left[..., None] + offsets


def aggregate(estimates: torch.Tensor, pix: torch.Tensor, numerator: torch.Tensor) -> None:
    """Add ``(G, K, d)`` patch estimates into a flat ``(H*W, C)`` image sum, in place.

    On CUDA ``index_add_`` adds with atomics, in an order that changes from run to run; ``index_put_`` with
    ``accumulate`` sorts the indices first, so the same input gives the same sum (the CPU's is ordered already)."""
    index, values = pix.reshape(-1), estimates.reshape(-1, numerator.shape[1])
    if numerator.is_cuda:
        numerator.index_put_((index,), values, accumulate=True)
    else:
        numerator.index_add_(0, index, values)


def coverage(pix: torch.Tensor, size: int, dtype=torch.float32) -> torch.Tensor:
    """How many grouped patch pixels fall on each of ``size`` pixels, ``(size,)``."""
    out = torch.zeros(size, dtype=dtype, device=pix.device)
    ones = torch.ones(pix.numel(), dtype=dtype, device=pix.device)
    return out.index_add_(0, pix.reshape(-1), ones)
