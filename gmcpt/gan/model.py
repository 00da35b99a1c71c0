"""Generator with conditioned feature modulation, and a WGAN-GP critic.

Generator (docs/design.md section 3, after Xu et al. 2019): a three-level U-Net of
residual blocks on 2x2 pixel blocks (space-to-depth). A conditioning net turns the auxiliary features (mask,
albedo, normal, depth, visibility and, optionally, the standard deviation of
the traced samples and the coverage of the feature pass) into a shared feature map; every residual block maps it,
pooled to the block's resolution, to a per-channel scale and shift applied
after each convolution (``h * (scale + 1) + shift``). The network starts from
a fixed fill of the sparse input (no parameters; ``base``: a push-pull
pyramid, or the feature-guided fill of ``interp``, which keeps the edges the
feature buffers see) and produces every pixel, traced ones included, so it
fills and denoises at once: either as a correction added to the fill
(``output="residual"``) or as per-pixel weights over the traced samples near
each pixel and the fill, plus a small correction (``output="kernel"``,
:class:`KernelHead`).

Default size (``GeneratorConfig()``): widths 32/48/96 at 1/2, 1/4 and 1/8
resolution, about 0.6 M parameters.

Critic: 4x4 stride-2 convolutions with LeakyReLU and no normalisation (batch norm
would break the per-sample gradient penalty), conditioned on the same
features, ending in a global mean and a linear layer.

All images are in the working domain divided by 255 (about 0..1.3).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

#: Feature channels: mask, albedo (3), normal (3), depth, visibility.
FEATURE_CHANNELS = 9


@dataclass(frozen=True)
class GeneratorConfig:
    """Sizes of the generator.

    Attributes
    ----------
    widths : channels at 1/2, 1/4 and 1/8 resolution (the top level runs on 2x2 pixel blocks).
    encoder_blocks, decoder_blocks : residual blocks per level (decoder: levels 0 and 1).
    condition_width : channels of the conditioning feature map.
    use_variance : add the standard deviation of each traced pixel's mean (working domain / 255, clipped
        at 1; :func:`gmcpt.gan.data.working_std`) as a feature.
    use_coverage : add the feature pass's ``coverage`` (the fraction of a pixel's feature rays on a
        diffuse surface, :func:`gmcpt.render.render_features`) as a feature: at a silhouette it says how
        much of the pixel the albedo describes.
    base : the fixed fill the network corrects: ``"push_pull"`` (feature-blind pyramid),
        ``"guided"`` (:func:`gmcpt.completion.classical.guided_fill`, runs on the CPU in numpy) or
        ``"guided_smooth"`` (the same, with the traced pixels smoothed too rather than kept).
    base_radius_scale : widens the guided fills' window (its radius times this; 1 = ``interp``'s).
    output : ``"residual"``: the network adds a correction to the fill; ``"kernel"``: it predicts,
        for every pixel, weights over the traced samples of a ``kernel_size`` square window and
        the fill (a softmax over those that exist) and adds a small correction to their weighted
        mean (see :class:`KernelHead`).
    kernel_size : side of the window of the ``"kernel"`` output (odd).
    """

    widths: tuple[int, int, int] = (32, 48, 96)
    encoder_blocks: tuple[int, int, int] = (1, 1, 2)
    decoder_blocks: tuple[int, int] = (1, 1)
    condition_width: int = 24
    use_variance: bool = True
    use_coverage: bool = False
    base: str = "push_pull"
    base_radius_scale: float = 1.0
    output: str = "residual"
    kernel_size: int = 9

    def __post_init__(self):
        if self.base not in BASES:
            raise ValueError(f"generator base must be one of {', '.join(BASES)}, got {self.base!r}")
        if self.output not in OUTPUTS:
            raise ValueError(f"generator output must be one of {', '.join(OUTPUTS)}, got {self.output!r}")
        if not self.base_radius_scale > 0:
            raise ValueError(f"base_radius_scale must be > 0, got {self.base_radius_scale!r}")
        if self.kernel_size < 1 or self.kernel_size % 2 == 0:
            raise ValueError(f"kernel_size must be a positive odd number, got {self.kernel_size}")

    @property
    def feature_channels(self) -> int:
        return FEATURE_CHANNELS + int(self.use_variance) + int(self.use_coverage)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "GeneratorConfig":
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in data.items()})


@dataclass(frozen=True)
class CriticConfig:
    """Channels of the critic's convolution stages (4x4, stride 2: each halves the resolution)."""

    widths: tuple[int, ...] = field(default=(32, 64, 96, 128))

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "CriticConfig":
        return cls(widths=tuple(data["widths"]))


def push_pull(values: torch.Tensor, weights: torch.Tensor) -> torch.Tensor:
    """Fill (B, C, H, W) ``values`` known where (B, 1, H, W) ``weights`` > 0 (pyramid push-pull)."""
    height, width = values.shape[-2:]
    if height == 1 and width == 1:
        return values * (weights > 0)
    pad = (0, width % 2, 0, height % 2)
    w = F.pad(weights, pad)
    v = F.pad(values * weights, pad)
    sum_w = F.avg_pool2d(w, 2) * 4
    coarse = push_pull(F.avg_pool2d(v, 2) * 4 / sum_w.clamp_min(1e-8), sum_w.clamp(max=1.0))
    up = F.interpolate(coarse, scale_factor=2, mode="nearest")[..., :height, :width]
    return weights * values + (1 - weights) * up


def guided_base(radiance: torch.Tensor, features: torch.Tensor, keep_samples: bool = True,
                radius_scale: float = 1.0) -> torch.Tensor:
    """The feature-guided fill of each (B, 3, H, W) ``radiance`` from its (B, F, H, W) ``features``
    (``keep_samples=False``: the traced pixels are smoothed by the same weights, see ``guided_fill``;
    ``radius_scale`` widens its window, :class:`~gmcpt.completion.classical.GuidedFillParams`)."""
    from ..completion.classical import GuidedFillParams, guided_fill

    params = GuidedFillParams(radius_scale=radius_scale)
    values = radiance.detach().permute(0, 2, 3, 1).cpu().numpy()
    aux = features.detach().permute(0, 2, 3, 1).cpu().numpy()
    filled = [guided_fill(values[i], aux[i, ..., 0] > 0, aux[i, ..., 1:FEATURE_CHANNELS], params, keep_samples)
              for i in range(len(values))]
    return torch.from_numpy(np.stack(filled)).permute(0, 3, 1, 2).to(radiance)


#: The fixed fills a generator can start from.
BASES = {"push_pull": lambda radiance, features, radius_scale=1.0: push_pull(radiance, features[:, :1]),
         "guided": guided_base,
         "guided_smooth": lambda radiance, features, radius_scale=1.0: guided_base(radiance, features, False,
                                                                                    radius_scale)}

#: How the last layer turns into an image (:class:`GeneratorConfig`.output).
OUTPUTS = ("residual", "kernel")


class KernelHead(nn.Module):
    """Per-pixel weights over the traced samples near a pixel, plus the fill, and a correction.

    From the top level's features (half resolution, ``width`` channels) a 1x1
    convolution predicts, for each full-resolution pixel (via ``pixel_shuffle``),
    ``k * k`` logits for the samples of its ``k x k`` window, one for the fill's
    value at the pixel, and 3 correction channels. Logits of untraced window
    pixels are dropped; the softmax of the rest weights the candidates, so the
    result is a convex combination of rendered samples (and the fill) that the
    network only has to choose, not to synthesise, which is what makes kernel
    prediction learn denoising from little data (Bako et al. 2017). The
    correction starts at 0; the logits start as a Gaussian of the distance
    (sigma ``k / 4``), so an untrained head is a spatial filter.

    Measured with the ``cpu`` preset and ``output="kernel"``, ``kernel_size=9`` (4000 steps,
    26 min on 2 threads): it learns faster (validation PSNR 28.32 dB after 250 steps against
    26.36 for the residual output) and ends higher on the validation split (30.42 against
    29.80 dB), but level on held-out scenes: test split (6 scenes, 128x128) ``gan`` 34.25
    against 34.12 dB; the 5 evaluation scenes (256x256, rates 0.2/0.3/0.4) ``gan`` 31.28/31.95/32.34
    against 31.41/31.90/32.22 and ``gan_pawnnm`` 32.04/32.75/33.05 against 32.18/32.82/33.19.
    Trained on 250 scenes instead of 150: validation 30.59 dB, ``gan`` 31.57/32.21/32.62 on the
    evaluation scenes but ``gan_pawnnm`` level (32.18/32.83/33.16), and 0.52 s a 256x256 frame on
    one core against 0.34 s (``benchmarks/gan_inference.py``), over the 0.5 s budget. The shipped
    preset keeps the residual output.
    """

    def __init__(self, width: int, kernel_size: int):
        super().__init__()
        self.kernel_size = kernel_size
        self.taps = kernel_size * kernel_size
        self.conv = nn.Conv2d(width, 4 * (self.taps + 1 + 3), 1)
        nn.init.zeros_(self.conv.weight)
        offsets = torch.arange(kernel_size, dtype=torch.float32) - kernel_size // 2
        distance2 = (offsets[:, None] ** 2 + offsets[None, :] ** 2).flatten()
        prior = torch.cat([-distance2 / (2 * (kernel_size / 4) ** 2), torch.zeros(4)])
        with torch.no_grad():  # pixel_shuffle takes channel c * 4 + i to output channel c
            self.conv.bias.copy_(prior.repeat_interleave(4))

    def forward(self, x: torch.Tensor, radiance: torch.Tensor, mask: torch.Tensor, fill: torch.Tensor) -> torch.Tensor:
        out = F.pixel_shuffle(self.conv(F.leaky_relu(x, 0.2)), 2)
        logits, fill_logit, correction = out.split([self.taps, 1, 3], dim=1)
        height, width = radiance.shape[-2:]
        pad = self.kernel_size // 2
        padded_radiance = F.pad(radiance, (pad, pad, pad, pad))
        padded_mask = F.pad(mask, (pad, pad, pad, pad))
        windows = [(dy, dx) for dy in range(self.kernel_size) for dx in range(self.kernel_size)]
        # a loop over the taps instead of F.unfold: 3x faster on the CPU (no (B, 3, k*k, H, W) copy)
        traced = torch.cat([padded_mask[..., dy:dy + height, dx:dx + width] for dy, dx in windows], 1)
        logits = logits.masked_fill(traced <= 0, float("-inf"))
        top = torch.maximum(logits.amax(1, keepdim=True), fill_logit)
        weights, fill_weight = torch.exp(logits - top), torch.exp(fill_logit - top)
        total = fill_weight * fill
        for tap, (dy, dx) in enumerate(windows):
            total = total + weights[:, tap:tap + 1] * padded_radiance[..., dy:dy + height, dx:dx + width]
        return total / (fill_weight + weights.sum(1, keepdim=True)) + correction


class ModulatedResBlock(nn.Module):
    """x + conv(CFM(conv(act(x)))) with conditioned feature modulation after each convolution."""

    def __init__(self, channels: int, condition_channels: int):
        super().__init__()
        self.conv1 = nn.Conv2d(channels, channels, 3, padding=1)
        self.conv2 = nn.Conv2d(channels, channels, 3, padding=1)
        self.modulation = nn.Conv2d(condition_channels, 4 * channels, 1)
        nn.init.zeros_(self.modulation.weight)
        nn.init.zeros_(self.modulation.bias)

    def forward(self, x: torch.Tensor, condition: torch.Tensor) -> torch.Tensor:
        scale1, shift1, scale2, shift2 = self.modulation(condition).chunk(4, dim=1)
        h = self.conv1(F.leaky_relu(x, 0.2))
        h = h * (scale1 + 1) + shift1
        h = self.conv2(F.leaky_relu(h, 0.2))
        return x + h * (scale2 + 1) + shift2


class ConditionNet(nn.Module):
    """Features (already space-to-depth) -> a shared conditioning map at three resolutions."""

    def __init__(self, in_channels: int, width: int):
        super().__init__()
        self.net = nn.Sequential(nn.Conv2d(in_channels, width, 3, padding=1), nn.LeakyReLU(0.2),
                                 nn.Conv2d(width, width, 3, padding=1), nn.LeakyReLU(0.2))

    def forward(self, features: torch.Tensor) -> list[torch.Tensor]:
        level0 = self.net(features)
        level1 = F.avg_pool2d(level0, 2)
        return [level0, level1, F.avg_pool2d(level1, 2)]


class Generator(nn.Module):
    """G(sparse radiance, features) -> the completed image, all in working domain / 255.

    ``forward(radiance, features)``: radiance (B, 3, H, W), 0 where not traced;
    features (B, F, H, W) with the mask first. H and W must be multiples of
    :attr:`multiple` (8).

    The first step is a lossless space-to-depth (``pixel_unshuffle`` by 2), so
    the U-Net's top level runs at half resolution on 4x the channels; the last
    step is the inverse (``pixel_shuffle``). This keeps the memory traffic of
    full-resolution activations out of the CPU inference time.
    """

    multiple = 8

    def __init__(self, config: GeneratorConfig = GeneratorConfig()):
        super().__init__()
        self.config = config
        w0, w1, w2 = config.widths
        c = config.condition_width
        self.condition = ConditionNet(4 * config.feature_channels, c)
        self.head = nn.Conv2d(4 * (3 + 3 + config.feature_channels), w0, 3, padding=1)
        self.enc0 = nn.ModuleList(ModulatedResBlock(w0, c) for _ in range(config.encoder_blocks[0]))
        self.down1 = nn.Conv2d(w0, w1, 3, stride=2, padding=1)
        self.enc1 = nn.ModuleList(ModulatedResBlock(w1, c) for _ in range(config.encoder_blocks[1]))
        self.down2 = nn.Conv2d(w1, w2, 3, stride=2, padding=1)
        self.enc2 = nn.ModuleList(ModulatedResBlock(w2, c) for _ in range(config.encoder_blocks[2]))
        self.up1 = nn.Conv2d(w2, w1, 1)
        self.dec1 = nn.ModuleList(ModulatedResBlock(w1, c) for _ in range(config.decoder_blocks[1]))
        self.up0 = nn.Conv2d(w1, w0, 1)
        self.dec0 = nn.ModuleList(ModulatedResBlock(w0, c) for _ in range(config.decoder_blocks[0]))
        if config.output == "kernel":
            self.tail = KernelHead(w0, config.kernel_size)
        else:
            self.tail = nn.Conv2d(w0, 3 * 4, 3, padding=1)
            nn.init.zeros_(self.tail.weight)
            nn.init.zeros_(self.tail.bias)

    @staticmethod
    def _run(blocks: nn.ModuleList, x: torch.Tensor, condition: torch.Tensor) -> torch.Tensor:
        for block in blocks:
            x = block(x, condition)
        return x

    def forward(self, radiance: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
        fill = BASES[self.config.base](radiance, features, radius_scale=self.config.base_radius_scale)
        cond = self.condition(F.pixel_unshuffle(features, 2))
        x = F.pixel_unshuffle(torch.cat([radiance, fill, features], 1), 2)
        x0 = self._run(self.enc0, self.head(x), cond[0])
        x1 = self._run(self.enc1, self.down1(F.leaky_relu(x0, 0.2)), cond[1])
        x2 = self._run(self.enc2, self.down2(F.leaky_relu(x1, 0.2)), cond[2])
        y1 = self._run(self.dec1, x1 + self.up1(F.interpolate(x2, scale_factor=2, mode="bilinear")), cond[1])
        y0 = self._run(self.dec0, x0 + self.up0(F.interpolate(y1, scale_factor=2, mode="bilinear")), cond[0])
        if self.config.output == "kernel":
            return self.tail(y0, radiance, features[:, :1], fill)
        return fill + F.pixel_shuffle(self.tail(F.leaky_relu(y0, 0.2)), 2)


class Critic(nn.Module):
    """D(image, features) -> one unbounded score per sample (WGAN), no normalisation layers."""

    def __init__(self, feature_channels: int = FEATURE_CHANNELS, config: CriticConfig = CriticConfig()):
        super().__init__()
        layers, channels = [], 3 + feature_channels
        for index, width in enumerate(config.widths):
            layers.append(nn.Conv2d(channels, width, 4, stride=2, padding=1))
            channels = width
        self.stages = nn.ModuleList(layers)
        self.score = nn.Linear(channels, 1)

    def features(self, image: torch.Tensor, features: torch.Tensor) -> list[torch.Tensor]:
        """Activations after each stage (usable as a perceptual feature extractor)."""
        x, outputs = torch.cat([image, features], 1), []
        for stage in self.stages:
            x = F.leaky_relu(stage(x), 0.2)
            outputs.append(x)
        return outputs

    def forward(self, image: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
        return self.score(self.features(image, features)[-1].mean(dim=(2, 3))).squeeze(1)


def parameter_count(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())
