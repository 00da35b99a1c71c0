"""The hybrid loss of paper Eq. 8, one function per term, plus the critic's side.

Every term compares the generator output ``G(c_in)`` with the reference
(docs/design.md section 3: the paper's equations mix up c_in, c_out and c_gt). Images are
(B, 3, H, W) in the working domain / 255.

- L_tex  :func:`texture_loss`: the Wasserstein generator term, ``-E[D(G(x))]``;
  the critic minimises :func:`critic_loss` + lambda * :func:`gradient_penalty`.
- L_per  :func:`perceptual_loss`: mean squared distance between feature maps of
  a fixed extractor (:class:`FixedFeatureExtractor`).
- L_sharp :func:`sharpness_loss`: mean squared distance between gradient
  magnitude maps (:func:`sharpness_map`).
- L_SSIM :func:`ssim_loss`: 1 - SSIM (Gaussian window 11, sigma 1.5).
- L1 :func:`l1_loss`: the added pixel term (docs/design.md section 3).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
import torch.nn.functional as F
from torch import nn


@dataclass(frozen=True)
class LossWeights:
    """Weights of Eq. 8 (paper values) and the extra L1 term; ``gp_lambda`` of Eq. 4."""

    alpha: float = 0.005   # texture (adversarial)
    beta: float = 0.0095   # perceptual
    gamma: float = 0.95    # sharpness
    omega: float = 0.095   # SSIM
    l1: float = 1.0        # added L1 (0 disables)
    gp_lambda: float = 10.0

    def to_dict(self) -> dict:
        return asdict(self)


def l1_loss(output: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean absolute difference."""
    return (output - target).abs().mean()


def l2_loss(output: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Mean squared difference."""
    return ((output - target) ** 2).mean()


def texture_loss(critic_fake: torch.Tensor) -> torch.Tensor:
    """L_tex for the generator: ``-E[D(G(x))]`` (the generator's part of the Wasserstein distance)."""
    return -critic_fake.mean()


def critic_loss(critic_real: torch.Tensor, critic_fake: torch.Tensor) -> torch.Tensor:
    """The critic minimises ``E[D(fake)] - E[D(real)]``, the negated Wasserstein estimate."""
    return critic_fake.mean() - critic_real.mean()


def wasserstein_distance(critic_real: torch.Tensor, critic_fake: torch.Tensor) -> torch.Tensor:
    """The critic's estimate ``E[D(real)] - E[D(fake)]`` (the curve of the paper's Fig. 4)."""
    return critic_real.mean() - critic_fake.mean()


def gradient_penalty(critic: nn.Module, real: torch.Tensor, fake: torch.Tensor,
                     features: torch.Tensor) -> torch.Tensor:
    """WGAN-GP term ``E[(||grad_x D(x_hat)||_2 - 1)^2]`` at random interpolates of real and fake.

    Multiply by lambda (10) yourself. ``fake`` should be detached.
    """
    epsilon = torch.rand(real.shape[0], 1, 1, 1, dtype=real.dtype, device=real.device)
    mixed = (epsilon * real + (1 - epsilon) * fake).requires_grad_(True)
    score = critic(mixed, features)
    gradient, = torch.autograd.grad(score.sum(), mixed, create_graph=True)
    return ((gradient.flatten(1).norm(dim=1) - 1) ** 2).mean()


def _gaussian_kernel(sigma: float, radius: int) -> torch.Tensor:
    x = torch.arange(-radius, radius + 1, dtype=torch.float32)
    kernel = torch.exp(-x ** 2 / (2 * sigma ** 2))
    return kernel / kernel.sum()


def _separable(image: torch.Tensor, kernel: torch.Tensor) -> torch.Tensor:
    """Depthwise separable filtering with reflect padding."""
    channels, radius = image.shape[1], kernel.numel() // 2
    horizontal = kernel.view(1, 1, 1, -1).repeat(channels, 1, 1, 1).to(image)
    vertical = kernel.view(1, 1, -1, 1).repeat(channels, 1, 1, 1).to(image)
    image = F.conv2d(F.pad(image, (radius, radius, 0, 0), mode="reflect"), horizontal, groups=channels)
    return F.conv2d(F.pad(image, (0, 0, radius, radius), mode="reflect"), vertical, groups=channels)


def ssim(output: torch.Tensor, target: torch.Tensor, data_range: float = 1.0) -> torch.Tensor:
    """Mean SSIM over pixels, channels and batch (Gaussian window sigma 1.5, radius 5)."""
    kernel = _gaussian_kernel(1.5, 5)
    c1, c2 = (0.01 * data_range) ** 2, (0.03 * data_range) ** 2
    mu_x, mu_y = _separable(output, kernel), _separable(target, kernel)
    xx = _separable(output * output, kernel) - mu_x ** 2
    yy = _separable(target * target, kernel) - mu_y ** 2
    xy = _separable(output * target, kernel) - mu_x * mu_y
    value = ((2 * mu_x * mu_y + c1) * (2 * xy + c2)) / ((mu_x ** 2 + mu_y ** 2 + c1) * (xx + yy + c2))
    return value.mean()


def ssim_loss(output: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """L_SSIM = 1 - SSIM(output, target)."""
    return 1 - ssim(output, target)


def sharpness_map(image: torch.Tensor) -> torch.Tensor:
    """Per-channel gradient magnitude from central differences (replicate border)."""
    padded = F.pad(image, (1, 1, 1, 1), mode="replicate")
    dx = (padded[..., 1:-1, 2:] - padded[..., 1:-1, :-2]) / 2
    dy = (padded[..., 2:, 1:-1] - padded[..., :-2, 1:-1]) / 2
    return torch.sqrt(dx ** 2 + dy ** 2 + 1e-8)


def sharpness_loss(output: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """L_sharp: mean squared difference of the sharpness maps."""
    return ((sharpness_map(output) - sharpness_map(target)) ** 2).mean()


class FixedFeatureExtractor(nn.Module):
    """The perceptual term's feature extractor phi: fixed, no parameters, no download.

    Three scales (the image, then 2x and 4x box-downsampled). At each scale the
    luminance and the two opponent-colour channels are filtered with a fixed
    bank of Gaussian-derivative filters (sigma 1: d/dx, d/dy, the three second
    derivatives, and a difference of Gaussians), and each response is
    half-wave rectified into its positive and negative parts (edges of either
    polarity, bars, blobs). This mimics the first layers of a pretrained CNN
    (oriented, multi-scale, rectified edge and blob detectors) with filters
    written down rather than learned, so it is deterministic and ships as code.
    """

    def __init__(self, scales: int = 3):
        super().__init__()
        self.scales = scales
        radius = 3
        x = torch.arange(-radius, radius + 1, dtype=torch.float32)
        yy, xx = torch.meshgrid(x, x, indexing="ij")
        g1 = torch.exp(-(xx ** 2 + yy ** 2) / 2)
        g1 = g1 / g1.sum()
        g2 = torch.exp(-(xx ** 2 + yy ** 2) / 8)
        g2 = g2 / g2.sum()
        bank = [-xx * g1, -yy * g1, (xx ** 2 - 1) * g1, (yy ** 2 - 1) * g1, xx * yy * g1, g1 - g2]
        bank = torch.stack([b - b.mean() for b in bank])            # zero DC: responds to structure only
        bank = bank / bank.abs().sum(dim=(1, 2), keepdim=True)
        self.register_buffer("bank", bank.unsqueeze(1).repeat(3, 1, 1, 1), persistent=False)  # (18, 1, 7, 7)
        opponent = torch.tensor([[1 / 3, 1 / 3, 1 / 3], [0.5, -0.5, 0.0], [0.25, 0.25, -0.5]])
        self.register_buffer("opponent", opponent.view(3, 3, 1, 1), persistent=False)

    def forward(self, image: torch.Tensor) -> list[torch.Tensor]:
        x = F.conv2d(image, self.opponent)
        outputs = []
        for scale in range(self.scales):
            if scale:
                x = F.avg_pool2d(x, 2)
            response = F.conv2d(F.pad(x, (3, 3, 3, 3), mode="reflect"), self.bank, groups=3)
            outputs.append(torch.cat([F.relu(response), F.relu(-response)], 1) * (2 ** scale))
        return outputs


def perceptual_loss(output_features: list[torch.Tensor], target_features: list[torch.Tensor]) -> torch.Tensor:
    """L_per: mean over feature maps of ``||phi(G(x)) - phi(y)||_F^2 / (w h d)``."""
    terms = [((a - b) ** 2).mean() for a, b in zip(output_features, target_features, strict=True)]
    return torch.stack(terms).mean()


def hybrid_loss(output: torch.Tensor, target: torch.Tensor, critic_fake: torch.Tensor | None,
                output_features: list[torch.Tensor], target_features: list[torch.Tensor],
                weights: LossWeights) -> tuple[torch.Tensor, dict[str, float]]:
    """Eq. 8 (+ L1): the generator's total loss and each term's value.

    ``critic_fake`` may be None (critic not yet enabled): the texture term is then 0.
    """
    terms = {"tex": texture_loss(critic_fake) if critic_fake is not None else output.new_zeros(()),
             "per": perceptual_loss(output_features, target_features),
             "sharp": sharpness_loss(output, target), "ssim": ssim_loss(output, target),
             "l1": l1_loss(output, target)}
    total = (weights.alpha * terms["tex"] + weights.beta * terms["per"] + weights.gamma * terms["sharp"]
             + weights.omega * terms["ssim"] + weights.l1 * terms["l1"])
    return total, {name: float(value.detach()) for name, value in terms.items()}


