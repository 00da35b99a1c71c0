"""The feature-guided fill's weighted mean on torch tensors, for a batch on a GPU
(:func:`gmcpt.image.fills.fill_batch`).

Each pixel becomes the mean of the traced pixels in a disc around it, weighted by ``exp(-d)`` with ``d`` the
scaled squared distance in space, albedo, normal, visibility and depth relative to the pixel's own: the numpy fill's
weights (:func:`gmcpt.image.fills.guided_fill`), walked one offset of the disc at a time over planes of the whole batch.
The generator's training batch is so filled where it lives, not on the host (docs/experiments.md); on a CPU the
numpy fill is as fast and runs its bands on the process's threads.
"""
from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F


def disc(radius: int) -> list[tuple[int, int]]:
    """The offsets ``(dy, dx)`` within ``radius`` pixels of a pixel, itself left out, in row-major order."""
    return [(dy, dx) for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)
            if (dy, dx) != (0, 0) and dy * dy + dx * dx <= radius * radius]


def weighted_mean(values: torch.Tensor, mask: torch.Tensor, compared: torch.Tensor, depth: torch.Tensor, radius: int,
                  scales: np.ndarray, depth_factor: float, sigma_space: float) -> tuple[torch.Tensor, torch.Tensor]:
    """(mean (B, C, H, W), summed weight (B, H, W)) of the traced pixels (``mask`` (B, H, W), true where traced)
    of ``values`` (B, C, H, W) in a disc of ``radius`` around each pixel, the pixel's own sample at weight 1:
    ``compared`` (B, K, H, W) features scaled by ``scales`` (K,), ``depth`` (B, H, W) by ``depth_factor`` over
    the pixel's own depth, space by ``sigma_space`` (:func:`gmcpt.image.fills.fill_batch` gives the numpy fill's)."""
    height, width = values.shape[2:]
    pad = (radius,) * 4
    scale = torch.as_tensor(scales, dtype=torch.float32, device=values.device)
    planes = F.pad(compared.float() * scale[:, None, None], pad, mode="replicate")
    centre = planes[..., radius:radius + height, radius:radius + width]
    depth = depth.float()
    depth_scale = float(depth_factor) / depth.clamp_min(1e-3)
    padded_depth = F.pad(depth[:, None], pad, mode="replicate")[:, 0]
    mask = mask.float()
    padded_values = F.pad(values.float() * mask[:, None], pad)
    padded_mask = F.pad(mask, pad)
    numerator = values.float() * mask[:, None]
    denominator = mask.clone()
    for dy, dx in disc(radius):
        there = (slice(radius + dy, radius + dy + height), slice(radius + dx, radius + dx + width))
        distance = (planes[(...,) + there] - centre).square_().sum(1)
        distance.add_(((padded_depth[(...,) + there] - depth) * depth_scale).square_())
        distance.add_((dy * dy + dx * dx) / (2 * sigma_space ** 2))
        weight = distance.neg_().exp_().mul_(padded_mask[(...,) + there])
        denominator.add_(weight)
        numerator.addcmul_(padded_values[(...,) + there], weight[:, None])
    return numerator / denominator.clamp_min(1e-12)[:, None], denominator
