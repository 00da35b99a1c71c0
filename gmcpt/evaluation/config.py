"""What an evaluation run measures: configs as data, and the completion variants it compares."""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..frame import DEFAULT_FEATURE_SPP
from ..sampling.masks import DEFAULT_PATTERN


@dataclass(frozen=True)
class EvalConfig:
    """Settings of one evaluation run (``python -m gmcpt eval``).

    Attributes
    ----------
    name : "quick" or "full"; printed in the report.
    procedural : how many held-out procedural scenes (test split seeds) join the bundled ones.
    resolution, spp, reference_spp, rates, seed : the quality protocol (docs/design.md section 6).
    feature_spp : primary samples per pixel of the feature pass, for the completion methods and for
        OIDN's albedo and normal (the product's default, :data:`gmcpt.frame.DEFAULT_FEATURE_SPP`).
    mask : sample placement of every table but the placement table (the product's default).
    placements, placement_variant : the placement table: ``placement_variant`` with each mask pattern at
        ``rates`` x ``spp``, beside path tracing at ``rate * spp`` spp + OIDN (read between whole counts);
        ``budget`` is not a mask but the budget chooser (:mod:`gmcpt.sampling.budget`) at ``rate * spp`` samples a
        pixel.
    default_placement : the placement of the default, the one the baselines are held against.
    placement_seeds : seeds (``seed``, ``seed + 1``, ...) whose mean PSNR the placement table gives for both
        baselines and the default; the other placements run at ``seed`` alone.
    variants : completion variants of the quality tables (keys of :data:`VARIANTS`).
    patch_sizes, patch_rates : the PSNR-against-patch-size sweep of PAWNNM (paper Fig. 12).
    grid_rate : rate of the image grids.
    path_spp : full-frame path tracing sample counts of the equal-time comparison.
    adaptive_budgets : mean samples per pixel of adaptive path tracing + OIDN in the equal-time comparison (at
        equal samples it runs at each rate x spp of the placement table).
    budget_rates, budget_spp : (rate, spp) grid of the completion methods in the equal-time comparison.
    budget_variants : the completion variants that enter the equal-time comparison (the default,
        :data:`DEFAULT_VARIANT`, at ``default_budgets`` samples a pixel, the others at the rate x spp grid).
    timing_resolutions : resolutions of the stage-timing table.
    timing_scene : scene of the stage-timing table.
    full_scene, full_size, full_reference_spp, full_budgets, full_path_spp, full_adaptive_budgets: the
        full-resolution check: on ``full_scene`` at ``full_size`` (W, H), the default at each of
        ``full_budgets`` samples a pixel, whose times are the budgets, against both baselines at their
        settings (reference cached under ``data/references``).
    repeats : timed runs of each render (the fastest frame counts; at equal time, after a warm-up round, the median).
    """

    name: str
    procedural: int
    resolution: int = 256
    spp: int = 16
    reference_spp: int = 4096
    rates: tuple[float, ...] = (0.2, 0.3, 0.4)
    seed: int = 0
    feature_spp: int = DEFAULT_FEATURE_SPP
    mask: str = DEFAULT_PATTERN
    placements: tuple[str, ...] = ("random", "stratified", "adaptive", "two_pass", "budget")
    default_placement: str = "budget"
    #: 10, not 3: with 3 a cell's lead moved between seeds by as much as the differences measured (docs/experiments.md)
    placement_seeds: int = 10
    placement_variant: str = "gan_oidn"
    variants: tuple[str, ...] = ("interp", "liu", "nnm", "pawnnm", "gan", "gan_pawnnm", "gan_oidn", "gan_pawnnm_oidn")
    patch_sizes: tuple[int, ...] = (5, 6, 7, 8)
    patch_rates: tuple[float, ...] = (0.3,)
    grid_rate: float = 0.3
    path_spp: tuple[int, ...] = (1, 2, 4, 8, 16, 32)
    adaptive_budgets: tuple[float, ...] = (2, 4, 8, 16, 32)
    budget_rates: tuple[float, ...] = (0.25, 0.5)
    budget_spp: tuple[int, ...] = (1, 4, 16, 32)
    budget_variants: tuple[str, ...] = ("pawnnm", "gan_pawnnm", "gan_oidn")
    default_budgets: tuple[float, ...] = (1, 2, 4, 8, 16)
    timing_resolutions: tuple[int, ...] = (128, 256)
    timing_scene: str = "still-life"
    full_scene: str = "sponza"
    full_size: tuple[int, int] = (1920, 1080)
    full_reference_spp: int = 512
    full_budgets: tuple[float, ...] = (2.4, 4.8)
    full_path_spp: tuple[int, ...] = (1, 2, 3, 4, 6, 8)
    full_adaptive_budgets: tuple[float, ...] = (1.5, 2, 3, 4, 6, 8)
    repeats: int = 2


QUICK = EvalConfig(name="quick", procedural=2, repeats=3)
FULL = EvalConfig(name="full", procedural=6, patch_sizes=(4, 5, 6, 7, 8, 9), patch_rates=(0.2, 0.3, 0.4),
                  path_spp=(1, 2, 4, 8, 16, 32, 64), budget_rates=(0.125, 0.25, 0.5),
                  budget_spp=(1, 2, 4, 8, 16, 32), timing_resolutions=(128, 256, 512), repeats=3)
CONFIGS = {config.name: config for config in (QUICK, FULL)}



@dataclass(frozen=True)
class Variant:
    """A completion method with options, under a label of the report."""

    label: str
    method: str
    summary: str
    patch_size: int | None = None

    def options(self) -> dict:
        """Keyword options for :func:`gmcpt.completion.complete`."""
        if self.patch_size is None:
            return {}
        from ..lowrank import DEFAULT

        return {"params": replace(DEFAULT, patch_size=self.patch_size, step=max(1, self.patch_size - 2))}


VARIANTS = {variant.label: variant for variant in (
    Variant("interp", "interp", "feature-guided interpolation (classical pre-completion alone)"),
    Variant("liu", "liu", "Liu et al. 2018 style: image-only push-pull fill + NNM"),
    Variant("nnm", "nnm", "classical pre-completion + block matching + NNM"),
    Variant("pawnnm", "pawnnm", "classical pre-completion + block matching + PAWNNM"),
    Variant("gan", "gan", "GAN pre-completion alone"),
    Variant("gan_pawnnm", "gan_pawnnm", "GAN pre-completion + block matching + PAWNNM (the paper's full method)"),
    Variant("gan_oidn", "gan_oidn", "GAN fill, the traced samples put back, Intel OIDN over the frame (the default)"),
    Variant("gan_pawnnm_oidn", "gan_pawnnm_oidn", "gan_pawnnm's fill, the traced samples put back, Intel OIDN"),
)}
#: the product's default method (:data:`gmcpt.completion.DEFAULT_METHOD`): the one the baselines are held against
DEFAULT_VARIANT = "gan_oidn"


def patch_variant(size: int) -> Variant:
    """PAWNNM with ``size`` x ``size`` patches stepped by ``size - 2`` (neighbours overlap by two pixels, as in
    the paper's section IV-C; 7 gives the default step of 5)."""
    return Variant(f"pawnnm-p{size}", "pawnnm", f"PAWNNM with {size}x{size} patches", patch_size=size)
