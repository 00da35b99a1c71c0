"""The measurements of an evaluation run, one function per table; each returns plain rows (dicts).

Every timing here is wall time on this machine, measured in the same run as
the quality figures. Renders are timed ``config.repeats`` times and the
fastest counts (the first call in a process traces Dr.Jit kernels);
completions run once.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..denoise import denoise_oidn
from ..metrics import all_metrics
from .baselines import fastest, render_full
from .config import SECOND_REFERENCE_SEED, VARIANTS, EvalConfig, Variant, patch_variant

Say = Callable[[str], None]


@dataclass
class LoadedScene:
    """An evaluation scene loaded at the evaluation resolution, with its reference and feature buffers."""

    name: str
    scene: object
    integrator: object
    reference: np.ndarray
    features: dict
    features_s: float
    images: dict = field(default_factory=dict)  # label -> image at the grid rate, for the image grid


def load(eval_scene, config: EvalConfig, say: Say) -> tuple[LoadedScene, dict]:
    """Load a scene, its cached reference, and measure the reference's noise level (a second reference)."""
    from ..render import render_features

    progress = lambda message: say(f"  {message} (cached after the first run)")  # noqa: E731
    reference = eval_scene.reference(config.resolution, config.reference_spp, progress=progress)
    second = eval_scene.reference(config.resolution, config.reference_spp, seed=SECOND_REFERENCE_SEED,
                                  progress=progress)
    noise = {"scene": eval_scene.name, "reference_spp": config.reference_spp,
             **{f"noise_{key}": value for key, value in all_metrics(second, reference).items()}}
    scene = eval_scene.load(config.resolution)
    integrator = scene.integrator()
    integrator = getattr(integrator, "integrator", integrator)  # the path tracer masked_path wraps
    sensor = scene.sensors()[0]
    features, features_s = fastest(lambda: render_features(scene, sensor, config.feature_spp), config.repeats)
    loaded = LoadedScene(eval_scene.name, scene, integrator, reference, features, features_s)
    loaded.images["reference"] = reference
    return loaded, noise


def sparse_frame(loaded: LoadedScene, rate: float, spp: int, config: EvalConfig, pattern: str | None = None):
    """(frame, render timings) of the fastest of ``config.repeats`` masked renders (``pattern``: default
    ``config.mask``)."""
    from ..render import RenderSettings, render_sparse_frame

    settings = RenderSettings(rate=rate, pattern=pattern or config.mask, spp=spp, seed=config.seed,
                              feature_spp=config.feature_spp)
    best = None
    for _ in range(max(1, config.repeats)):
        frame, timings = render_sparse_frame(loaded.scene, loaded.integrator, settings=settings)
        if best is None or sum(timings.values()) < sum(best[1].values()):
            best = (frame, timings)
    return best


def run_variant(frame, variant: Variant, reference: np.ndarray) -> tuple[np.ndarray, dict, dict]:
    """(image, metrics, timings) of one completion variant on one frame."""
    from ..completion import complete

    result = complete(frame, variant.method, **variant.options())
    return result.image, all_metrics(result.image, reference), result.timings


def quality(loaded: LoadedScene, config: EvalConfig, say: Say) -> list[dict]:
    """Every quality variant, and the patch-size sweep, at every rate (paper Tables 1-2, Figs. 10 and 12)."""
    rows = []
    for rate in config.rates:
        frame, render_timings = sparse_frame(loaded, rate, config.spp, config)
        if rate == config.grid_rate:
            loaded.images["sparse input"] = frame.radiance
        variants = [VARIANTS[label] for label in config.variants]
        if rate in config.patch_rates:
            variants += [patch_variant(size) for size in config.patch_sizes]
        for variant in variants:
            image, metrics, timings = run_variant(frame, variant, loaded.reference)
            rows.append({"scene": loaded.name, "rate": rate, "spp": config.spp, "variant": variant.label,
                         **metrics, "completion_s": timings["completion_s"], **_prefixed(render_timings)})
            say(f"  {loaded.name} rate {rate:.2f} {variant.label:<12} PSNR {metrics['psnr']:6.2f} dB  "
                f"SSIM {metrics['ssim']:.3f}  ({timings['completion_s']:.2f} s)")
            if rate == config.grid_rate and variant.label in config.variants:
                loaded.images[variant.label] = image
        if rate == config.grid_rate:
            samples = max(1, round(rate * config.spp))
            noisy = render_full(loaded.scene, loaded.integrator, samples, config.seed + 17)
            loaded.images[f"path {samples} spp + OIDN"] = denoise_oidn(noisy, loaded.features["albedo"],
                                                                        loaded.features["normal"])
    return rows


def equal_time(loaded: LoadedScene, config: EvalConfig, say: Say) -> list[dict]:
    """Quality and total wall time of every contender at every setting of the equal-time comparison.

    Path tracing: a full-frame render. Path tracing + OIDN: the same render,
    a 1-spp albedo/normal pass and the denoiser. Completion variants: the
    masked render (its features pass included) and the completion.
    """
    rows = []
    albedo, normal = loaded.features["albedo"], loaded.features["normal"]
    for spp in config.path_spp:
        noisy, render_s = fastest(lambda: render_full(loaded.scene, loaded.integrator, spp, config.seed + 17),
                                  config.repeats)
        denoised, oidn_s = fastest(lambda: denoise_oidn(noisy, albedo, normal), config.repeats)
        for contender, image, seconds in (("path", noisy, render_s),
                                          ("path+oidn", denoised, render_s + loaded.features_s + oidn_s)):
            rows.append({"scene": loaded.name, "contender": contender, "rate": 1.0, "spp": spp,
                         "samples_per_pixel": float(spp), "seconds": seconds, **all_metrics(image, loaded.reference)})
        say(f"  {loaded.name} path {spp:>3} spp: {rows[-2]['psnr']:6.2f} dB, + OIDN {rows[-1]['psnr']:6.2f} dB "
            f"({render_s:.2f} s + {loaded.features_s + oidn_s:.2f} s)")
    for rate in config.budget_rates:
        for spp in config.budget_spp:
            frame, render_timings = sparse_frame(loaded, rate, spp, config)
            for label in config.budget_variants:
                _, metrics, timings = run_variant(frame, VARIANTS[label], loaded.reference)
                seconds = sum(render_timings.values()) + timings["completion_s"]
                rows.append({"scene": loaded.name, "contender": label, "rate": rate, "spp": spp,
                             "samples_per_pixel": rate * spp, "seconds": seconds, **metrics})
                say(f"  {loaded.name} {label} rate {rate:.3f} x {spp:>2} spp: {metrics['psnr']:6.2f} dB "
                    f"({seconds:.2f} s)")
    return rows


def placement(loaded: LoadedScene, config: EvalConfig, say: Say) -> list[dict]:
    """Equal samples: ``config.placement_variant`` with each mask pattern, and path tracing at the same total
    sample count (``round(rate * spp)`` per pixel, full frame) + OIDN, at every rate."""
    rows = []
    variant = VARIANTS[config.placement_variant]
    albedo, normal = loaded.features["albedo"], loaded.features["normal"]
    for rate in config.rates:
        samples = max(1, round(rate * config.spp))
        noisy = render_full(loaded.scene, loaded.integrator, samples, config.seed + 17)
        rows.append({"scene": loaded.name, "rate": rate, "variant": "path+oidn", "samples_per_pixel": samples,
                     **all_metrics(denoise_oidn(noisy, albedo, normal), loaded.reference)})
        say(f"  {loaded.name} rate {rate:.2f} path {samples} spp + OIDN: {rows[-1]['psnr']:6.2f} dB")
        for pattern in config.placements:
            frame, render_timings = sparse_frame(loaded, rate, config.spp, config, pattern)
            _, metrics, timings = run_variant(frame, variant, loaded.reference)
            rows.append({"scene": loaded.name, "rate": rate, "variant": pattern, "method": variant.label,
                         "samples_per_pixel": frame.info["path_samples"] / frame.mask.size, **metrics,
                         "completion_s": timings["completion_s"], **_prefixed(render_timings)})
            say(f"  {loaded.name} rate {rate:.2f} {variant.label} {pattern:<10}: {metrics['psnr']:6.2f} dB "
                f"(mask {render_timings['mask_s'] * 1000:.0f} ms, render {render_timings['render_s']:.2f} s)")
    return rows


def stage_timings(eval_scene, config: EvalConfig, say: Say) -> list[dict]:
    """Seconds per stage of each budget variant at each resolution (rate 0.3, ``config.spp``)."""
    from ..completion import complete

    rows = []
    for resolution in config.timing_resolutions:
        scene = eval_scene.load(resolution)
        integrator = scene.integrator()
        integrator = getattr(integrator, "integrator", integrator)
        loaded = LoadedScene(eval_scene.name, scene, integrator, np.zeros((resolution, resolution, 3), np.float32),
                             {}, 0.0)
        frame, render_timings = sparse_frame(loaded, 0.3, config.spp, config)
        for label in config.budget_variants:
            timings = complete(frame, VARIANTS[label].method).timings
            row = {"scene": eval_scene.name, "resolution": resolution, "variant": label, "rate": 0.3,
                   "spp": config.spp, "features_s": render_timings["features_s"],
                   "render_s": render_timings["render_s"],
                   "pre_completion_s": timings.get("pre_completion_s", 0.0),
                   "block_matching_s": timings.get("block_matching_s", 0.0), "svd_s": timings.get("svd_s", 0.0),
                   "aggregation_s": timings.get("aggregation_s", 0.0), "wiener_s": timings.get("wiener_s", 0.0),
                   "denoise_s": timings.get("denoise_s", 0.0),
                   "completion_s": timings["completion_s"]}
            row["total_s"] = sum(render_timings.values()) + row["completion_s"]
            rows.append(row)
            say(f"  timings {eval_scene.name} {resolution}px {label}: total {row['total_s']:.2f} s")
    return rows


def _prefixed(timings: dict) -> dict:
    return {f"frame_{key}": value for key, value in timings.items()}
