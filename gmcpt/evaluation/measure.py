"""The measurements of an evaluation run, one function per table; each returns plain rows (dicts).

Every timing here is wall time on this machine, measured in the same run as
the quality figures. Renders are timed ``config.repeats`` times and the
fastest counts (the first call in a process traces Dr.Jit kernels); in the
equal-time comparison every contender's whole pipeline runs so, in one warm
process: guides, probe, placement, render and completion for the completion
methods; render, guides and OIDN for the baselines, and the median run counts
(:func:`median_seconds`). Each run there draws seeds of
its own, and the figures are the means over the runs: one seed's PSNR moves by
0.1-0.2 dB, as much as 5-10 % more samples buy. A baseline's guides are the
project's own feature pass at its own samples (:func:`baseline_guides`: OIDN
prefers it to Mitsuba's albedo on scenes with metals), and it is charged the time
of Mitsuba's ``aov`` pass (albedo, normal) at those samples (:func:`guide_pass_seconds`).
"""
from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from ..image.denoise import denoise_oidn
from ..image.metrics import all_metrics
from ..sampling.budget import SPARSE_SPP
from ..seeds import BASELINE_SEED_OFFSET, RUN_SEED_STEP, SECOND_REFERENCE_SEED
from .baselines import render_full
from .config import DEFAULT_VARIANT, VARIANTS, EvalConfig, Variant, patch_variant

Say = Callable[[str], None]
#: where the full-resolution check caches its reference (ignored by git: a 1920x1080 EXR is 20 MB)
FULL_REFERENCES = Path(__file__).resolve().parents[2] / "data" / "references"


@dataclass
class LoadedScene:
    """An evaluation scene loaded at the evaluation resolution, with its reference (each contender renders its
    own feature pass: the default inside its frame, the baselines by :func:`baseline_guides`)."""

    name: str
    scene: object
    integrator: object
    reference: np.ndarray
    images: dict = field(default_factory=dict)  # label -> image at the grid rate, for the image grid


def load(eval_scene, config: EvalConfig, say: Say) -> tuple[LoadedScene, dict]:
    """Load a scene, its cached reference, and measure the reference's noise level (a second reference)."""
    from ..render.scene import path_integrator

    progress = lambda message: say(f"  {message} (cached after the first run)")  # noqa: E731
    reference = eval_scene.reference(config.resolution, config.reference_spp, progress=progress)
    second = eval_scene.reference(config.resolution, config.reference_spp, seed=SECOND_REFERENCE_SEED,
                                  progress=progress)
    noise = {"scene": eval_scene.name, "reference_spp": config.reference_spp,
             **{f"noise_{key}": value for key, value in all_metrics(second, reference).items()}}
    scene = eval_scene.load(config.resolution)
    integrator = path_integrator(scene)
    loaded = LoadedScene(eval_scene.name, scene, integrator, reference)
    loaded.images["reference"] = reference
    return loaded, noise


#: the placement table's name for the budget chooser (:mod:`gmcpt.sampling.budget`), which is no mask pattern
BUDGET = "budget"


def baseline_guides(loaded: LoadedScene, samples_per_pixel: float, seed: int) -> dict:
    """OIDN's albedo and normal for a baseline of ``samples_per_pixel`` path samples: a feature pass of as many
    primary samples, ``max(1, round(samples_per_pixel))``, what a renderer accumulates over its own samples
    (Cycles' denoising passes, Mitsuba's ``aov`` integrator). Its time is :func:`guide_pass_seconds`."""
    from ..render.kernels import render_features

    return render_features(loaded.scene, loaded.scene.sensors()[0], baseline_guide_rays(samples_per_pixel), seed)


def baseline_guide_rays(samples_per_pixel: float) -> int:
    """Primary rays a pixel of a baseline's guides (:func:`baseline_guides`): as many as its path samples."""
    return max(1, round(samples_per_pixel))


def guide_pass_seconds(loaded: LoadedScene, samples_per_pixel: float, seed: int) -> float:
    """Seconds of Mitsuba's ``aov`` integrator (albedo, shading normal) at ``max(1, round(samples_per_pixel))``
    spp: what a baseline's guides cost a Mitsuba user."""
    import mitsuba as mi

    start = time.perf_counter()
    np.asarray(mi.render(loaded.scene, integrator=_aov_integrator(mi.variant()),
                         spp=baseline_guide_rays(samples_per_pixel), seed=seed))
    return time.perf_counter() - start


@functools.cache
def _aov_integrator(variant: str):
    """Mitsuba's ``aov`` integrator for albedo and shading normal, made once per variant: loading a plugin is no
    part of what a baseline's frame costs."""
    import mitsuba as mi

    return mi.load_dict({"type": "aov", "aovs": "albedo:albedo,normal:sh_normal"})


def sparse_frame(loaded: LoadedScene, rate: float, spp: int, config: EvalConfig, pattern: str | None = None):
    """(frame, render timings) of the fastest of ``config.repeats`` masked renders (``pattern``: default
    ``config.mask``; :data:`BUDGET`: the budget chooser at ``rate * spp`` samples a pixel)."""
    from ..sampling.strategies import render_sparse_frame

    settings = _settings(rate, spp, config, pattern)
    best = None
    for _ in range(max(1, config.repeats)):
        frame, timings = render_sparse_frame(loaded.scene, loaded.integrator, settings=settings)
        if best is None or sum(timings.values()) < sum(best[1].values()):
            best = (frame, timings)
    return best


def _settings(rate: float, spp: int, config: EvalConfig, pattern: str | None = None):
    """The render settings of a completion contender (see :func:`sparse_frame`)."""
    from ..sampling.strategies import RenderSettings

    if pattern == BUDGET:
        return RenderSettings(budget=rate * spp, seed=config.seed, feature_spp=config.feature_spp)
    return RenderSettings(rate=rate, pattern=pattern or config.mask, spp=spp, seed=config.seed,
                          feature_spp=config.feature_spp)


def adaptive_oidn(loaded: LoadedScene, budget: float, seed: int, features: dict):
    """(image, info, timings) of adaptive path tracing + OIDN at ``budget`` mean samples a pixel, its samples drawn
    with ``seed`` (:func:`gmcpt.sampling.adaptive.render_adaptive`; ``features``: OIDN's guides,
    :func:`baseline_guides`)."""
    from ..sampling.adaptive import AdaptiveSettings, render_adaptive

    settings = AdaptiveSettings(budget=budget, seed=seed)
    return render_adaptive(loaded.scene, loaded.integrator, settings, features=features,
                           guide_rays=baseline_guide_rays(budget))


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
            noisy = render_full(loaded.scene, loaded.integrator, samples, config.seed + BASELINE_SEED_OFFSET)
            guides = baseline_guides(loaded, samples, config.seed + BASELINE_SEED_OFFSET)
            loaded.images[f"path {samples} spp + OIDN"] = denoise_oidn(noisy, guides["albedo"], guides["normal"],
                                                                        baseline_guide_rays(samples))
    return rows


def _path_oidn(loaded: LoadedScene, spp: int, seed: int, guides: dict) -> tuple[np.ndarray, np.ndarray, dict]:
    """(denoised, noisy, timings) of path tracing + OIDN with ``guides`` (:func:`baseline_guides`), charged an
    ``aov`` pass (:func:`guide_pass_seconds`)."""
    timings = {}
    start = time.perf_counter()
    noisy = render_full(loaded.scene, loaded.integrator, spp, seed)
    timings["render_s"] = time.perf_counter() - start
    timings["guides_s"] = guide_pass_seconds(loaded, spp, seed)
    start = time.perf_counter()
    denoised = denoise_oidn(noisy, guides["albedo"], guides["normal"], baseline_guide_rays(spp))
    timings["denoise_s"] = time.perf_counter() - start
    return denoised, noisy, timings


@dataclass
class _Setting:
    """One setting of the equal-time table: ``run(index)`` (seeds of its own per run) gives a result whose first
    item is the image; ``row`` its row without the measurements. ``noisy`` (path tracing + OIDN): the result's
    unfiltered image too, whose render time is the result's third item's ``render_s``."""

    row: dict
    run: Callable[[int], tuple]
    noisy: Callable[[tuple], np.ndarray] | None = None
    metrics: list = field(default_factory=list)
    noisy_metrics: list = field(default_factory=list)
    times: dict = field(default_factory=dict)  # timing round -> seconds
    render_times: dict = field(default_factory=dict)  # timing round -> its path render's seconds (``noisy``)
    warm_ups: int = 1  # runs in each warm-up round

    @property
    def seconds(self) -> float:
        """The median of its timed runs (:func:`median_seconds`)."""
        return median_seconds(self.times)

    @property
    def render_seconds(self) -> float:
        return median_seconds(self.render_times)

    def round_seconds(self, rounds: int, render: bool = False) -> list:
        """Its time in each of ``rounds`` timing rounds, None where it did not run."""
        times = self.render_times if render else self.times
        return [times.get(index) for index in range(rounds)]


def median_seconds(times: dict) -> float:
    """A setting's time: the median of its timed runs (inf before any). Not the fastest run: on a machine whose
    pace moves by 10% from one run to the next, one lucky run set a setting's time and moved a scene's verdict by
    5% (docs/experiments.md); the median moves less, and the verdict pairs runs of one round (:mod:`.report`)."""
    return float(np.median(list(times.values()))) if times else np.inf


#: Rounds over every equal-time setting before the counted ones, neither timed nor counted, for every contender
#: alike: a setting's first run in a process compiles kernels and loads weights, and the default's first frames
#: read their scene (the sparse way's cost, a dense frame's first pass) with samples other than path tracing's
#: at the same seed. One such frame among three counted runs moved a setting's mean by 0.17 dB, as much as 6%
#: more time buys (docs/experiments.md).
WARM_UP_ROUNDS = 1

#: The default's runs in a warm-up round: from budget 4 its readings wait on one another (the placement's, then
#: the denoiser's, :mod:`gmcpt.sampling.large_model`), and with one run the second fell in a counted run (the veach lamp
#: at budget 8 lost 0.15 dB to path tracing + OIDN at the same seeds in one evaluation, level in every other).
DEFAULT_WARM_UPS = 2


def timed_runs(repeats: int) -> int:
    """Counted runs of each equal-time setting for a config's ``repeats`` (two at least), after the
    :data:`WARM_UP_ROUNDS`."""
    return max(2, repeats)


def all_rounds(repeats: int) -> int:
    """Rounds of the equal-time comparison for a config's ``repeats``: warm-up and counted."""
    return WARM_UP_ROUNDS + timed_runs(repeats)


#: Settings whose time after the counted rounds is shorter than this get :data:`EXTRA_TIMING_RUNS` more runs before
#: the last round, timed only (each repeats an earlier run's seeds, its quality not counted twice): a 0.1 s frame's
#: time moved by 5-15% from one run to the next, and the fastest of three 0.3-0.6 s runs by 2-3%, as much as the
#: default and path tracing + OIDN differ (docs/experiments.md), while these runs cost the evaluation about 45 s a
#: scene.
CHEAP_SETTING_SECONDS = 1.0
EXTRA_TIMING_RUNS = 4


def timing_rounds(repeats: int) -> int:
    """Timing rounds of the equal-time comparison: the counted rounds, then the :data:`EXTRA_TIMING_RUNS`."""
    return timed_runs(repeats) + EXTRA_TIMING_RUNS


def _timed_run(setting: _Setting, index: int, slot: int) -> tuple:
    """``setting.run(index)``, its time and its path render's kept as timing round ``slot``'s."""
    start = time.perf_counter()
    result = setting.run(index)
    setting.times[slot] = time.perf_counter() - start
    if setting.noisy is not None:
        setting.render_times[slot] = result[2]["render_s"]
    return result


def _in_rounds(settings: list[_Setting], repeats: int, reference: np.ndarray,
               done: Callable[[_Setting, tuple], None]) -> None:
    """Run every setting :func:`all_rounds` times, one round over all of them after another; after the
    :data:`WARM_UP_ROUNDS` each run is timed alone (its metrics after the clock): a setting's time is the median of
    its timed runs (each kept by timing round, :meth:`_Setting.round_seconds`), its quality the mean over the counted
    ones. Rounds, not a setting's runs back to back, so that a machine whose
    pace drifts over minutes (this one's moved by 10%) slows every contender alike; every other round runs
    backwards. Before the last round, the settings faster than :data:`CHEAP_SETTING_SECONDS` get timed runs of
    their own (:data:`EXTRA_TIMING_RUNS`). ``done(setting, result)`` after a setting's last run, with that run's
    result (no earlier result is kept)."""
    rounds, counted = all_rounds(repeats), timed_runs(repeats)

    def order(index: int) -> list[_Setting]:
        # every other round backwards, the last forwards: no setting always follows the same one (the default's
        # budget-1 frame came right after PAWNNM and the generator in every round; right after them it measured
        # 3-6 ms slower in one test, no slower in the next), and the last round still ends each setting in the
        # order the progress line expects
        return list(reversed(settings)) if (rounds - 1 - index) % 2 == 1 else settings

    for index in range(rounds):
        if index == rounds - 1:
            for extra in range(EXTRA_TIMING_RUNS):
                for setting in order(index + 1 + extra):
                    if setting.seconds < CHEAP_SETTING_SECONDS:
                        # the seeds of one of the counted rounds before the last; slots after the counted ones
                        _timed_run(setting, WARM_UP_ROUNDS + extra % (counted - 1), counted + extra)
        for setting in order(index):
            if index < WARM_UP_ROUNDS:
                for _ in range(setting.warm_ups):
                    setting.run(index)
                continue
            result = _timed_run(setting, index, index - WARM_UP_ROUNDS)
            setting.metrics.append(all_metrics(result[0], reference))
            if setting.noisy is not None:
                setting.noisy_metrics.append(all_metrics(setting.noisy(result), reference))
            if index == rounds - 1:
                done(setting, result)




def equal_time(loaded: LoadedScene, config: EvalConfig, say: Say, images: dict | None = None) -> list[dict]:
    """Quality and total wall time of every contender at every setting of the equal-time comparison.

    Path tracing: a full-frame render. Path tracing + OIDN: the same render, guides (:func:`baseline_guides`, charged
    :func:`guide_pass_seconds`) and the denoiser. Adaptive path tracing + OIDN: the same with the samples placed
    adaptively. Completion variants: feature pass, placement, masked render and completion, the default at
    ``config.default_budgets`` samples a pixel, the others at ``config.budget_rates`` x ``config.budget_spp``.
    Each timed warm, in rounds (:func:`_in_rounds`). Both baselines' renders and guides draw the seeds the default's
    frames do (common random numbers: a dense frame at an integral budget is the same render as path tracing's, an
    adaptive one the same samples as adaptive path tracing's, with guides of as many rays, from a pass or from the
    render's own first hits (:mod:`gmcpt.sampling.dense`), so the contenders differ by what they do and their time, not
    by one seed's luck, which moved a setting's PSNR by 0.2-0.4 dB). ``images``: where given, the last run's image of
    each setting goes in it, keyed ``(contender, rate * spp)`` (``gmcpt compare`` shows them side by side); the
    measurements are the same either way.
    """
    base = {"scene": loaded.name}
    runs = all_rounds(config.repeats)

    def seed(run: int) -> int:
        return config.seed + RUN_SEED_STEP * run

    settings = []
    for spp in config.path_spp:
        guides = [baseline_guides(loaded, spp, seed(run)) for run in range(runs)]
        settings.append(_Setting({**base, "contender": "path+oidn", "rate": 1.0, "spp": spp,
                                  "samples_per_pixel": float(spp)},
                                 lambda run, spp=spp, guides=guides: _path_oidn(loaded, spp, seed(run), guides[run]),
                                 noisy=lambda result: result[1]))
    for budget in config.adaptive_budgets:
        guides = [baseline_guides(loaded, budget, seed(run)) for run in range(runs)]

        def adaptive(run, budget=budget, guides=guides):
            image, info, _ = adaptive_oidn(loaded, budget, seed(run), guides[run])
            guide_pass_seconds(loaded, budget, seed(run))
            return image, info

        settings.append(_Setting({**base, "contender": "adaptive+oidn", "rate": 1.0, "spp": budget,
                                  "samples_per_pixel": float(budget)}, adaptive))
    variants = [(label, rate, spp, None) for rate in config.budget_rates for spp in config.budget_spp
                for label in config.budget_variants if label != DEFAULT_VARIANT]
    if DEFAULT_VARIANT in config.budget_variants:
        variants += [(DEFAULT_VARIANT, budget / SPARSE_SPP, SPARSE_SPP, BUDGET) for budget in config.default_budgets]
    for label, rate, spp, pattern in variants:
        def pipeline(run, label=label, rate=rate, spp=spp, pattern=pattern):
            from ..pipeline import render_and_complete

            variant = VARIANTS[label]
            rendered = render_and_complete(loaded.scene, loaded.integrator,
                                           _settings(rate, spp, replace(config, seed=seed(run)), pattern),
                                           variant.method, variant.options())
            return rendered.image, rendered.frame.info

        settings.append(_Setting({**base, "contender": label, "rate": rate, "spp": spp, "pattern": pattern}, pipeline,
                                 warm_ups=DEFAULT_WARM_UPS if pattern == BUDGET else 1))

    rows = []

    def done(setting: _Setting, last: tuple) -> None:
        row, metrics = dict(setting.row), _mean_metrics(setting.metrics)
        image, info = last[0], last[1]
        contender, pattern = row["contender"], row.pop("pattern", None)
        if setting.noisy is not None:
            noisy = _mean_metrics(setting.noisy_metrics)
            rows.append({**row, "contender": "path", "seconds": setting.render_seconds,
                         "round_seconds": setting.round_seconds(slots, render=True), **noisy})
            if images is not None:
                images[("path", float(row["spp"]))] = setting.noisy(last)
            say(f"  {loaded.name} path {row['spp']:>3} spp: {noisy['psnr']:6.2f} dB, + OIDN {metrics['psnr']:6.2f} dB "
                f"({setting.render_seconds:.2f} s, {setting.seconds:.2f} s in all)")
        elif contender == "adaptive+oidn":
            say(f"  {loaded.name} adaptive {row['spp']:g} spp + OIDN: {metrics['psnr']:6.2f} dB ({setting.seconds:.2f} s)")
        else:
            row["samples_per_pixel"] = info.path_samples / image.shape[0] / image.shape[1]
            if pattern:
                row["budget_choice"] = info.budget_choice
            where = (f"budget {row['rate'] * row['spp']:g} ({info.budget_choice})" if pattern
                     else f"rate {row['rate']:.3f} x {row['spp']:>2} spp")
            say(f"  {loaded.name} {contender} {where}: {metrics['psnr']:6.2f} dB ({setting.seconds:.2f} s)")
        rows.append({**row, "seconds": setting.seconds, "round_seconds": setting.round_seconds(slots), **metrics})
        if images is not None:
            images[(contender, row["rate"] * row["spp"])] = image

    slots = timing_rounds(config.repeats)
    # settings of like cost side by side in each round, so that the runs a verdict pairs ran close in time
    settings.sort(key=lambda setting: setting.row.get("samples_per_pixel", setting.row["rate"] * setting.row["spp"]))
    _in_rounds(settings, config.repeats, loaded.reference, done)
    return rows


def _mean_metrics(runs: list[dict]) -> dict:
    """Each metric's mean over ``runs`` (PSNR as the mean of the dB values)."""
    return {key: float(np.mean([run[key] for run in runs])) for key in runs[0]}


def whole_counts(samples: float) -> tuple[int, int]:
    """The whole samples a pixel at and above ``samples``, at least 1 each: the counts :func:`path_oidn_at` renders,
    among them ``baseline_guide_rays(samples)``."""
    low = max(1, math.floor(samples))
    return low, max(low, math.ceil(samples))


def path_oidn_at(loaded: LoadedScene, samples: float, seeds: list[int], guides: dict[int, dict]) -> list[dict]:
    """Metrics of full-frame path tracing + OIDN at ``samples`` a pixel, one dict for each of ``seeds``: a
    renderer traces whole samples a pixel, so between two whole counts (:func:`whole_counts`) each metric is read
    between theirs, linearly in log samples (the other contenders of the equal-samples table trace exactly
    ``samples``). ``guides``: each seed's :func:`baseline_guides` of each count, by seed, then by count."""
    low, high = whole_counts(samples)
    at = {}
    for count in {low, high}:
        at[count] = [all_metrics(denoise_oidn(render_full(loaded.scene, loaded.integrator, count, seed),
                                              guides[seed][count]["albedo"], guides[seed][count]["normal"],
                                              baseline_guide_rays(count)), loaded.reference) for seed in seeds]
    if high == low:
        return at[low]
    weight = math.log(samples / low) / math.log(high / low)
    return [{key: (1 - weight) * below[key] + weight * above[key] for key in below}
            for below, above in zip(at[low], at[high])]


def placement(loaded: LoadedScene, config: EvalConfig, say: Say) -> list[dict]:
    """Equal samples: ``config.placement_variant`` with each mask pattern, and path tracing at the same samples a
    pixel (full frame, :func:`path_oidn_at`) + OIDN, at every rate. Both baselines and the
    default are the means over ``config.placement_seeds`` seeds: one seed's PSNR moves by tenths of a dB
    (docs/experiments.md); each seed draws its own guides too, as the default's frames and the equal-time runs do (one
    guide pass shared by every seed put its one draw's luck, up to 0.07 dB, in the whole mean)."""
    rows = []
    variant = VARIANTS[config.placement_variant]
    seeds = [config.seed + offset for offset in range(max(1, config.placement_seeds))]
    baseline_seeds = [seed + BASELINE_SEED_OFFSET for seed in seeds]
    for rate in config.rates:
        samples = max(1.0, rate * config.spp)
        # a guide pass a count and seed: adaptive path tracing's rays are one of the two counts
        passes = {seed: {count: baseline_guides(loaded, count, seed) for count in set(whole_counts(samples))}
                  for seed in baseline_seeds}
        runs = path_oidn_at(loaded, samples, baseline_seeds, passes)
        rows.append({"scene": loaded.name, "rate": rate, "variant": "path+oidn", "samples_per_pixel": samples,
                     "seeds": len(seeds), **_mean_metrics(runs)})
        runs, spent = [], 0
        for seed in baseline_seeds:
            image, info, _ = adaptive_oidn(loaded, rate * config.spp, seed, passes[seed][baseline_guide_rays(samples)])
            runs.append(all_metrics(image, loaded.reference))
            spent = info.path_samples / image.shape[0] / image.shape[1]
        rows.append({"scene": loaded.name, "rate": rate, "variant": "adaptive+oidn", "samples_per_pixel": spent,
                     "seeds": len(seeds), **_mean_metrics(runs)})
        say(f"  {loaded.name} rate {rate:.2f} path {samples:g} spp + OIDN: {rows[-2]['psnr']:6.2f} dB, adaptive "
            f"{rate * config.spp:g} spp + OIDN: {rows[-1]['psnr']:6.2f} dB (means of {len(seeds)} seeds)")
        for pattern in config.placements:
            frame, render_timings = sparse_frame(loaded, rate, config.spp, config, pattern)
            _, metrics, timings = run_variant(frame, variant, loaded.reference)
            runs = [metrics]
            if pattern == config.default_placement:  # the other seeds untimed: one render each
                for seed in seeds[1:]:
                    other, _ = sparse_frame(loaded, rate, config.spp, replace(config, seed=seed, repeats=1), pattern)
                    runs.append(run_variant(other, variant, loaded.reference)[1])
            rows.append({"scene": loaded.name, "rate": rate, "variant": pattern, "method": variant.label,
                         "samples_per_pixel": frame.info.path_samples / frame.mask.size, "seeds": len(runs),
                         **_mean_metrics(runs), "completion_s": timings["completion_s"], **_prefixed(render_timings),
                         **({"budget_choice": frame.info.budget_choice} if frame.info.budget_choice is not None
                            else {})})
            say(f"  {loaded.name} rate {rate:.2f} {variant.label} {pattern:<10}: {rows[-1]['psnr']:6.2f} dB "
                f"(mask {render_timings['mask_s'] * 1000:.0f} ms, render {render_timings['render_s']:.2f} s"
                + (f", mean of {len(runs)} seeds)" if len(runs) > 1 else ")"))
    return rows


def full_resolution(eval_scene, config: EvalConfig, say: Say) -> list[dict]:
    """The equal-time comparison (:func:`equal_time`) at ``config.full_size`` on one scene: the default at
    ``config.full_budgets`` samples a pixel against both baselines at ``config.full_path_spp`` and
    ``config.full_adaptive_budgets``. The reference is cached under ``data/references``."""
    from ..render.scene import path_integrator
    from .reference import render_reference

    progress = lambda message: say(f"  {message} (cached under data/references after the first run)")  # noqa: E731
    # passes of 32 spp: the sampler holds a state per lane, 1 GB for a 1920x1080 pass of 32
    reference = render_reference(eval_scene.path, config.full_size, config.full_reference_spp, pass_spp=32,
                                 progress=progress, without=eval_scene.without, folder=FULL_REFERENCES)
    scene = eval_scene.load(config.full_size)
    integrator = path_integrator(scene)
    loaded = LoadedScene(eval_scene.name, scene, integrator, reference)
    full = replace(config, path_spp=config.full_path_spp, adaptive_budgets=config.full_adaptive_budgets,
                   budget_variants=(DEFAULT_VARIANT,), default_budgets=config.full_budgets)
    size = "x".join(map(str, config.full_size))
    return [dict(row, size=size) for row in equal_time(loaded, full, say)]


def stage_timings(eval_scene, config: EvalConfig, say: Say) -> list[dict]:
    """Seconds per stage of each budget variant at each resolution (rate 0.3, ``config.spp``)."""
    from ..completion import complete
    from ..render.scene import path_integrator

    rows = []
    for resolution in config.timing_resolutions:
        scene = eval_scene.load(resolution)
        integrator = path_integrator(scene)
        loaded = LoadedScene(eval_scene.name, scene, integrator, np.zeros((resolution, resolution, 3), np.float32))
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
