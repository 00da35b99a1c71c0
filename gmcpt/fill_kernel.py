"""The feature-guided fill's weighted mean (:func:`gmcpt.fills.fill_batch`) on torch tensors, on the CPU or a GPU.

Each pixel becomes the mean of the traced pixels in a disc around it, weighted by ``exp(-d)`` with ``d`` the
scaled squared distance in space, albedo, normal, visibility and depth relative to the pixel's own. The disc is
walked one offset at a time over planes of a whole batch. On the CPU the frame goes in bands of rows, so that a
band's planes stay in the cache across the offsets; on a GPU in one piece. The generator's training batch is
filled where it lives, not on the host (docs/experiments.md).
"""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F

#: Pixels of a band of rows on the CPU (all images of the batch together): at 256x256 and 1920x1080 the fill took
#: 14.6 / 455 ms in bands of 1 << 17, 20.5 / 635 in bands of 1 << 15 and 13.1 / 1389 in one piece.
BAND_PIXELS = 1 << 17
#: the feature channels of (albedo 3, normal 3, depth, visibility) that are compared as they are; depth is relative
_COMPARED = [0, 1, 2, 3, 4, 5, 7]
_DEPTH = 6


def disc(radius: int) -> list[tuple[int, int]]:
    """The offsets ``(dy, dx)`` within ``radius`` pixels of a pixel, itself left out, in row-major order."""
    return [(dy, dx) for dy in range(-radius, radius + 1) for dx in range(-radius, radius + 1)
            if (dy, dx) != (0, 0) and dy * dy + dx * dx <= radius * radius]


def weighted_mean(values: torch.Tensor, mask: torch.Tensor, features: torch.Tensor, radius: int,
                  params) -> tuple[torch.Tensor, torch.Tensor]:
    """(mean (B, C, H, W), summed weight (B, H, W)) of the traced pixels (``mask`` (B, H, W), 1 where traced) of
    ``values`` (B, C, H, W) in a disc of ``radius`` around each pixel, the pixel's own sample at weight 1;
    ``features`` (B, 8, H, W) and the bandwidths ``params`` as :func:`gmcpt.fills.guided_fill` takes them."""
    batch, _, height, width = values.shape
    pad = (radius,) * 4
    scale = math.sqrt(0.5) * torch.tensor([1 / params.sigma_albedo] * 3 + [1 / params.sigma_normal] * 3
                                          + [1 / params.sigma_visibility], dtype=torch.float32, device=values.device)
    planes = F.pad(features[:, _COMPARED].float() * scale[:, None, None], pad, mode="replicate")
    depth = features[:, _DEPTH].float()
    depth_scale = (math.sqrt(0.5) / params.sigma_depth) / depth.clamp_min(1e-3)
    padded_depth = F.pad(depth[:, None], pad, mode="replicate")[:, 0]
    mask = mask.float()
    padded_values = F.pad(values.float() * mask[:, None], pad)
    padded_mask = F.pad(mask, pad)
    sigma_space = max(radius / 2.0, 0.5)
    rows = height if values.device.type != "cpu" else max(1, BAND_PIXELS // (batch * width))
    sums = [_band_sums(planes, padded_depth, depth_scale, padded_values, padded_mask, radius, sigma_space,
                       top, min(top + rows, height)) for top in range(0, height, rows)]
    numerator = torch.cat([numerator for numerator, _ in sums], dim=2)
    denominator = torch.cat([denominator for _, denominator in sums], dim=1)
    return numerator / denominator.clamp_min(1e-12)[:, None], denominator


def _band_sums(planes, depth, depth_scale, values, mask, radius: int, sigma_space: float, top: int, bottom: int):
    """(numerator (B, C, n, W), denominator (B, n, W)) of the weighted mean for output rows ``top:bottom``; every
    input but ``depth_scale`` is padded by ``radius`` on each side."""
    width = depth_scale.shape[2]
    here = (slice(radius + top, radius + bottom), slice(radius, radius + width))
    centre, centre_depth, scale = planes[(...,) + here], depth[(...,) + here], depth_scale[:, top:bottom]
    numerator = values[(...,) + here].clone()
    denominator = mask[(...,) + here].clone()
    for dy, dx in disc(radius):
        there = (slice(radius + top + dy, radius + bottom + dy), slice(radius + dx, radius + dx + width))
        distance = (planes[(...,) + there] - centre).square_().sum(1)
        distance.add_(((depth[(...,) + there] - centre_depth) * scale).square_())
        distance.add_((dy * dy + dx * dx) / (2 * sigma_space ** 2))
        weight = distance.neg_().exp_().mul_(mask[(...,) + there])
        denominator.add_(weight)
        numerator.addcmul_(values[(...,) + there], weight[:, None])
    return numerator, denominator
