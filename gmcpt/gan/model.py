"""Generator with conditioned feature modulation, and a WGAN-GP critic.

Generator (docs/design.md section 3, after Xu et al. 2019): a three-level U-Net of
residual blocks on 2x2 pixel blocks (space-to-depth). A conditioning net turns the auxiliary features (mask,
albedo, normal, depth, visibility and, optionally, the standard deviation of
the traced samples and the coverage of the feature pass) into a shared feature map; every residual block maps it,
pooled to the block's resolution, to a per-channel scale and shift applied
after each convolution (``h * (scale + 1) + shift``). The network starts from
a fixed fill of the sparse input (no parameters: :func:`smoothed_fill`, the
feature-guided fill of ``interp`` with the traced pixels smoothed too, which
keeps the edges the feature buffers see) and adds a correction to every
pixel, traced ones included, so it fills and denoises at once.

Default size (``GeneratorConfig()``, the shipped ``cpu`` preset): widths 16/48/96 at 1/2, 1/4 and 1/8
resolution, 1/2/3 encoder and 1/2 decoder blocks, a conditioning map of 16 channels, about 0.78 M
parameters and 1.9 GMAC for a 256x256 frame: the half-resolution level, where most of the arithmetic is,
is thin, the coarse ones keep their width. Against the 32/48/96, 2/2/3, 2/2 and 24 of before (3.5 GMAC):
2.2x faster on one core (0.10 s against 0.22 s at 256x256), 0.08-0.15 dB lower after the low-rank stage
(docs/experiments.md).

Critic: 4x4 stride-2 convolutions with LeakyReLU and no normalisation (batch norm
would break the per-sample gradient penalty), conditioned on the same
features, ending in a global mean and a linear layer.

All images are in the working domain divided by 255 (about 0..1.3).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import torch
import torch.nn.functional as F
from torch import nn

from ..image.fills import fill_batch
from .inputs import FEATURE_CHANNELS, smoothed_fill_arrays
from .retired import drop_retired


@dataclass(frozen=True)
class GeneratorConfig:
    """Sizes of the generator.

    Attributes
    ----------
    widths : channels at 1/2, 1/4 and 1/8 resolution (the top level runs on 2x2 pixel blocks).
    encoder_blocks, decoder_blocks : residual blocks per level (decoder: levels 0 and 1).
    condition_width : channels of the conditioning feature map.
    use_variance : add the standard deviation of each traced pixel's mean (working domain / 255, clipped
        at 1; :func:`gmcpt.gan.inputs.working_std`) as a feature.
    use_coverage : add the feature pass's ``coverage`` (the fraction of a pixel's feature rays on a
        diffuse surface, :func:`gmcpt.render.kernels.render_features`) as a feature: at a silhouette it says how
        much of the pixel the albedo describes.
    """

    widths: tuple[int, int, int] = (16, 48, 96)
    encoder_blocks: tuple[int, int, int] = (1, 2, 3)
    decoder_blocks: tuple[int, int] = (1, 2)
    condition_width: int = 16
    use_variance: bool = True
    use_coverage: bool = True

    @property
    def feature_channels(self) -> int:
        return FEATURE_CHANNELS + int(self.use_variance) + int(self.use_coverage)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "GeneratorConfig":
        """The config stored in a weights file (keys of retired options dropped, :mod:`gmcpt.gan.retired`)."""
        data = drop_retired("generator", data)
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


def smoothed_fill(radiance: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
    """The fill the generator corrects: the feature-guided fill of each (B, 3, H, W) ``radiance`` from its
    (B, F, H, W) ``features``, with the traced pixels smoothed by the same weights (``guided_fill`` with
    ``keep_samples=False``; no parameters, no gradient). On a GPU in torch there (``fill_batch``), else in numpy."""
    if radiance.device.type != "cpu":
        with torch.no_grad():
            return fill_batch(radiance, features[:, 0] > 0, features[:, 1:FEATURE_CHANNELS], keep_samples=False)
    values, aux = (tensor.detach().permute(0, 2, 3, 1).numpy() for tensor in (radiance, features))
    return torch.from_numpy(smoothed_fill_arrays(values, aux)).permute(0, 3, 1, 2).to(radiance)


def space_to_depth_conv(conv: nn.Conv2d, x: torch.Tensor) -> torch.Tensor:
    """``conv(pixel_unshuffle(x, 2))`` for a 3x3, padding-1 ``conv``, as one 6x6 stride-2 convolution of ``x``.

    The same weights, rearranged (unshuffled channel ``4 c + 2 i + j`` is pixel ``(i, j)`` of channel ``c``'s
    2x2 block), so the same result to float rounding; it skips the unshuffled copy of the input, which
    costs as much as the convolution on large frames (1024x1024: 0.26 s instead of 0.40 s a layer).
    """
    out_channels, unshuffled, k, _ = conv.weight.shape
    weight = conv.weight.view(out_channels, unshuffled // 4, 2, 2, k, k).permute(0, 1, 4, 2, 5, 3)
    return F.conv2d(x, weight.reshape(out_channels, unshuffled // 4, 2 * k, 2 * k), conv.bias, stride=2, padding=2)


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
        scale1, shift1, scale2, shift2 = self._modulation(condition).chunk(4, dim=1)
        h = torch.addcmul(shift1, self.conv1(F.leaky_relu(x, 0.2)), scale1)
        return x + torch.addcmul(shift2, self.conv2(F.leaky_relu(h, 0.2)), scale2)

    def _modulation(self, condition: torch.Tensor) -> torch.Tensor:
        """The four maps, the scales with their +1: one product with the bias as the weight of a channel of
        ones (a 1x1 convolution with a bias first copies the bias into every pixel of its output, slowly)."""
        bias = self.modulation.bias.view(4, -1) + torch.tensor([[1.0], [0.0], [1.0], [0.0]],
                                                                dtype=condition.dtype, device=condition.device)
        weight = torch.cat([self.modulation.weight, bias.view(-1, 1, 1, 1)], 1)
        ones = torch.ones_like(condition[:, :1])
        return F.conv2d(torch.cat([condition, ones], 1), weight)


class ConditionNet(nn.Module):
    """Features -> a shared conditioning map at three resolutions (1/2, 1/4, 1/8: the first convolution
    sees the features space-to-depth)."""

    def __init__(self, in_channels: int, width: int):
        super().__init__()
        self.net = nn.Sequential(nn.Conv2d(in_channels, width, 3, padding=1), nn.LeakyReLU(0.2),
                                 nn.Conv2d(width, width, 3, padding=1), nn.LeakyReLU(0.2))

    def forward(self, features: torch.Tensor) -> list[torch.Tensor]:
        first, act, second, _ = self.net  # a Sequential still, so the weights keep their names
        level0 = act(second(act(space_to_depth_conv(first, features))))
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
        self.tail = nn.Conv2d(w0, 3 * 4, 3, padding=1)
        nn.init.zeros_(self.tail.weight)
        nn.init.zeros_(self.tail.bias)

    @staticmethod
    def _run(blocks: nn.ModuleList, x: torch.Tensor, condition: torch.Tensor) -> torch.Tensor:
        for block in blocks:
            x = block(x, condition)
        return x

    def forward(self, radiance: torch.Tensor, features: torch.Tensor, fill: torch.Tensor | None = None) -> torch.Tensor:
        """The completed image; ``fill``, where given, is the frame's :func:`smoothed_fill` computed beforehand."""
        fill = smoothed_fill(radiance, features) if fill is None else fill
        return fill + self.correction(radiance, features, fill)

    def correction(self, radiance: torch.Tensor, features: torch.Tensor, fill: torch.Tensor) -> torch.Tensor:
        """What the generator adds to ``fill``: the network proper, without the numpy fill (so it exports)."""
        cond = self.condition(features)
        x0 = self._run(self.enc0, space_to_depth_conv(self.head, torch.cat([radiance, fill, features], 1)), cond[0])
        x1 = self._run(self.enc1, self.down1(F.leaky_relu(x0, 0.2)), cond[1])
        x2 = self._run(self.enc2, self.down2(F.leaky_relu(x1, 0.2)), cond[2])
        # the 1x1 convolutions before the upsampling, on a quarter of the pixels: both are linear and bilinear
        # weights sum to 1, so the order does not matter (to float rounding)
        y1 = self._run(self.dec1, x1 + F.interpolate(self.up1(x2), scale_factor=2, mode="bilinear"), cond[1])
        y0 = self._run(self.dec0, x0 + F.interpolate(self.up0(y1), scale_factor=2, mode="bilinear"), cond[0])
        return F.pixel_shuffle(self.tail(F.leaky_relu(y0, 0.2)), 2)


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
        """Activations after each stage."""
        x, outputs = torch.cat([image, features], 1), []
        for stage in self.stages:
            x = F.leaky_relu(stage(x), 0.2)
            outputs.append(x)
        return outputs

    def forward(self, image: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
        return self.score(self.features(image, features)[-1].mean(dim=(2, 3))).squeeze(1)


def parameter_count(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())
