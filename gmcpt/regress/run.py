"""Check a suite against its goldens, or (re)make the goldens.

Every input is checked before the first render (goldens present, scenes load,
sizes match), so bad input ends with one :class:`~gmcpt.errors.GmcptError` and
no output. ``update`` writes the goldens and the manifest under temporary
names and renames them only once all are complete.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import GmcptError
from .manifest import Golden, Settings, Suite, manifest_json
from .measure import SceneResult, compare, failures, render_check, render_golden, thresholds, timed



@dataclass(frozen=True)
class Prepared:
    """A scene ready to render: loaded, with its golden image (None while updating) and load time."""

    name: str
    scene: object
    load_s: float
    golden: np.ndarray | None = None


def load(suite: Suite, name: str, settings: Settings | None = None) -> tuple[object, float]:
    """(the loaded Mitsuba scene ``name`` at the suite's resolution, seconds it took)."""
    from ..render.scene import load_scene

    spec = suite.spec(name)
    settings = settings or suite.settings
    return timed(load_scene, spec.path(suite.folder), settings.resolution, None, spec.without)


def film_size(scene) -> tuple[int, int]:
    size = scene.sensors()[0].film().crop_size()
    return int(size[0]), int(size[1])


def prepare_check(suite: Suite, names: list[str]) -> list:
    """Load each scene and its golden; skipped scenes become their SceneResult. Raises on bad input."""
    from ..completion import check_size
    from ..io.exr import read_rgb_exr

    prepared = []
    for name in names:
        reason = suite.skip_reason(name)
        if reason is not None:
            prepared.append(SceneResult(name, {}, {}, skipped=reason))
            continue
        if name not in suite.goldens or not suite.golden_path(name).is_file():
            raise GmcptError(f"scene {name} has no golden in {suite.golden_folder} (make it with --update)")
        golden = read_rgb_exr(suite.golden_path(name))
        scene, load_s = load(suite, name)
        width, height = film_size(scene)
        if golden.shape[:2] != (height, width):
            raise GmcptError(f"scene {name} renders {width}x{height} but its golden is "
                             f"{golden.shape[1]}x{golden.shape[0]} (resolution changed; --update remakes it)")
        check_size(suite.settings.method, height, width)
        prepared.append(Prepared(name, scene, load_s, golden))
    return prepared


def check_one(suite: Suite, item: Prepared, seed: int = 0) -> SceneResult:
    """Render ``item`` cheaply with ``seed`` and compare it with its golden."""
    image, render_s = timed(render_check, item.scene, suite.settings, seed)
    metrics, error_map = compare(image, item.golden, suite.settings.block)
    golden = suite.goldens[item.name]
    return SceneResult(item.name, metrics, dict(golden.thresholds), failures(metrics, golden.thresholds),
                       item.load_s + render_s, golden.render_s, item.golden, image, error_map)


def check_suite(suite: Suite, names: list[str] | None = None, seed: int = 0,
                on_result: Callable[[SceneResult], None] | None = None) -> list[SceneResult]:
    """Check the scenes ``names`` (all when None) of ``suite``; ``on_result`` sees each result as it comes."""
    results = []
    for item in prepare_check(suite, suite.select(names)):
        result = item if isinstance(item, SceneResult) else check_one(suite, item, seed)
        if on_result:
            on_result(result)
        results.append(result)
    return results


def calibrate(item: Prepared, golden: np.ndarray, settings: Settings) -> tuple[dict, dict]:
    """(thresholds, calibration record): the check with seeds 1..N against ``golden``."""
    seeds = list(range(1, settings.seeds + 1))
    record = {"seeds": seeds, "flip": [], "block_psnr": [], "psnr": [], "relmse": [], "check_s": []}
    for seed in seeds:
        image, render_s = timed(render_check, item.scene, settings, seed)
        metrics, _ = compare(image, golden, settings.block)
        for key, value in metrics.items():
            record[key].append(round(value, 6))
        record["check_s"].append(round(item.load_s + render_s, 3))
    return thresholds(record, settings), record


def update_suite(suite: Suite, settings: Settings, names: list[str] | None = None,
                 say: Callable[[str], None] = lambda message: None) -> dict:
    """Render the goldens of ``names`` (all when None), calibrate their thresholds, write them.

    Goldens of scenes left out (``names``, or absent optional scenes) stay as they are; those of scenes
    that no longer exist are dropped on a full update. Returns the new {name: Golden}.
    """
    from ..completion import check_size

    if settings.seeds < 2:
        raise GmcptError(f"--seeds must be >= 2 (a spread needs two values), got {settings.seeds}")
    if settings.golden_spp < 1 or settings.spp < 1:
        raise GmcptError("--golden-spp and --spp must be >= 1")
    partial = bool(names)
    if partial and suite.goldens and settings != suite.settings:
        raise GmcptError("settings differ from the suite's: update every scene (no --scene) to change them")
    goldens = dict(suite.goldens) if partial else {}
    specs = dict(suite.specs)
    prepared = []
    for name in suite.select(names):
        reason = suite.skip_reason(name)
        if reason is not None:
            say(f"{name}: skipped, {reason}")
            if name in suite.goldens:
                goldens[name] = suite.goldens[name]
        elif not partial and not suite.spec(name).path(suite.folder).is_file():
            say(f"{name}: scene file gone, golden dropped")
            specs.pop(name)
        else:
            scene, load_s = load(suite, name, settings)
            check_size(settings.method, *reversed(film_size(scene)))
            prepared.append(Prepared(name, scene, load_s))
    images = {}
    for item in prepared:
        image, render_s = timed(render_golden, item.scene, settings)
        limits, record = calibrate(item, image, settings)
        goldens[item.name] = Golden(suite.spec(item.name), film_size(item.scene), item.load_s + render_s,
                                    limits, record)
        images[item.name] = image
        say(f"{item.name}: golden {settings.golden_spp} spp in {item.load_s + render_s:.1f} s; "
            f"thresholds FLIP <= {limits['flip']:.4f}, block PSNR >= {limits['block_psnr']:.2f} dB "
            f"(check {np.median(record['check_s']):.2f} s, seeds {record['seeds'][0]}-{record['seeds'][-1]})")
    write_goldens(suite, settings, goldens, images, specs)
    return goldens


def write_goldens(suite: Suite, settings: Settings, goldens: dict, images: dict, specs: dict) -> list[Path]:
    """Write ``images`` ({name: (H, W, 3)}) and the manifest of ``goldens`` and ``specs``, atomically.

    Golden files of scenes no longer in ``goldens`` are removed.
    """
    from ..io.exr import write_exr
    from ..io.files import atomic_output

    suite.golden_folder.mkdir(parents=True, exist_ok=True)
    written = []
    with contextlib.ExitStack() as stack:
        for name, image in images.items():
            path = suite.golden_path(name)
            temporary = stack.enter_context(atomic_output(path))
            write_exr(temporary, {c: image[..., i] for i, c in enumerate("RGB")},
                      {"gmcpt_golden": f"{name}, {settings.golden_spp} spp"})
            written.append(path)
        manifest = stack.enter_context(atomic_output(suite.manifest_path))
        Path(manifest).write_text(manifest_json(settings, goldens, specs))
        written.append(suite.manifest_path)
    for name in set(suite.goldens) - set(goldens):
        with contextlib.suppress(FileNotFoundError):
            suite.golden_path(name).unlink()
    return written
