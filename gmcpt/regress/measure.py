"""Render a golden and a cheap check, compare them, and set thresholds from the check's spread.

The check is the product itself: ``masked_path`` at the suite's rate and spp,
then its completion method. Its distance to the golden never reaches zero (the
completion is neither noise-free nor unbiased), so a scene's thresholds are
measured, not chosen: on ``--update`` the check runs with seeds 1..N (12),
and each gated metric's threshold lies ``sigmas`` (5) standard deviations past
its mean over those seeds, and at least a margin past it (20% of the mean
FLIP; 2 dB of block PSNR). Fewer seeds or sigmas proved fragile: with 8 seeds
and 4 sigmas the Cornell box's 8-seed spread (0.25 dB) was half its 40-seed
one (0.47 dB), and 2 of 40 unchanged seeds came within 0.15 dB of the threshold.

Gated metrics (:data:`GATES`): FLIP (mean, on tonemapped sRGB; larger is worse)
and block PSNR (:func:`gmcpt.image.metrics.block_psnr`, 8x8-pixel blocks; smaller is
worse). PSNR and relMSE are reported beside them. Block PSNR separates
noise from change best: averaging over blocks takes out the check's per-pixel
noise and keeps a change that spans a few pixels. Measured at rate 0.5, 16 spp
(golden 256 spp; tests/test_regress.py's 64x64 box, 10 seeds unchanged, 5
changed): unchanged block PSNR 41.3-43.5 dB, FLIP 0.074-0.083 (thresholds
39.4 dB, 0.093); sphere moved by 5% of the frame 29.8-30.5 dB, 0.113-0.121;
light +20% 26.9-27.1 dB, 0.213-0.217. On the bundled still life at 96x96
(golden 1024 spp) its red sphere moved by 5% of the frame stays under the
FLIP threshold (0.093-0.099 against 0.103) but not the block PSNR one (34.8-35.4
dB against 37.3; unchanged 39.0-41.5 over 40 seeds), and PSNR moves by 1.1 dB
only (30.4-31.1 dB unchanged, 28.9-29.3 dB moved).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..seeds import REFERENCE_FIRST_SEED as GOLDEN_SEED
from .manifest import Settings

#: gated metrics: "max" where a larger value is worse, "min" where a smaller one is
GATES = {"flip": "max", "block_psnr": "min"}


@dataclass(frozen=True)
class SceneResult:
    """One scene's check against its golden.

    Attributes
    ----------
    name : the scene.
    metrics : ``flip``, ``block_psnr``, ``psnr``, ``relmse`` of the check against the golden.
    thresholds : limits of the gated metrics (:data:`GATES`).
    failed : gated metrics past their thresholds; empty when the scene passes.
    check_s, golden_s : seconds the check took (load, render, completion) and the golden took when made.
    golden, image, flip_map : the images, for the report: (H, W, 3) linear, (H, W, 3) linear, (H, W).
    skipped : why the scene was not checked (its other fields are then empty), else None.
    """

    name: str
    metrics: dict
    thresholds: dict
    failed: tuple = ()
    check_s: float = 0.0
    golden_s: float = 0.0
    golden: np.ndarray | None = None
    image: np.ndarray | None = None
    flip_map: np.ndarray | None = None
    skipped: str | None = None

    @property
    def passed(self) -> bool:
        return self.skipped is None and not self.failed


def render_golden(scene, settings: Settings) -> np.ndarray:
    """Plain path tracing of the whole frame at ``settings.golden_spp`` (the scene's own integrator)."""
    from ..evaluation.reference import render_full

    return render_full(scene, settings.golden_spp, GOLDEN_SEED, pass_spp=min(256, settings.golden_spp))


def render_check(scene, settings: Settings, seed: int) -> np.ndarray:
    """The cheap check: masked render at the suite's rate and spp, completed by its method; same seed, same image."""
    from ..render.scene import masked_integrator

    integrator = masked_integrator(scene, rate=settings.rate, seed=int(seed), completion=settings.method)
    return integrator.render_frame(scene, spp=settings.spp).image


def timed(function, *args):
    """(function(*args), seconds it took)."""
    start = time.perf_counter()
    value = function(*args)
    return value, time.perf_counter() - start


def compare(image: np.ndarray, golden: np.ndarray, block: int = 8) -> tuple[dict, np.ndarray]:
    """(metrics of ``image`` against ``golden``, per-pixel FLIP map)."""
    from ..image.metrics import block_psnr, flip_map, psnr, relmse

    error_map, mean_flip = flip_map(image, golden)
    metrics = {"flip": mean_flip, "block_psnr": block_psnr(image, golden, block),
               "psnr": psnr(image, golden), "relmse": relmse(image, golden)}
    return metrics, error_map


def thresholds(calibration: dict, settings: Settings) -> dict:
    """Thresholds of the gated metrics from their values over the calibration seeds.

    ``calibration`` maps each metric of :data:`GATES` to its values; the threshold is
    ``mean +- max(sigmas * std, margin)`` (std with ddof 1), the margin being ``flip_margin * mean``
    for FLIP and ``psnr_margin_db`` for block PSNR.
    """
    limits = {}
    for metric, direction in GATES.items():
        values = np.asarray(calibration[metric], dtype=np.float64)
        mean = float(values.mean())
        spread = settings.sigmas * float(values.std(ddof=1)) if values.size > 1 else 0.0
        margin = settings.flip_margin * mean if metric == "flip" else settings.psnr_margin_db
        distance = max(spread, margin)
        limits[metric] = round(mean + distance if direction == "max" else mean - distance, 6)
    return limits


def failures(metrics: dict, limits: dict) -> tuple:
    """The gated metrics of ``metrics`` past their ``limits``."""
    past = []
    for metric, direction in GATES.items():
        value, limit = metrics[metric], limits[metric]
        if (value > limit) if direction == "max" else (value < limit):
            past.append(metric)
    return tuple(past)
