"""Render the procedural dataset: one seeded, versioned ``.npz`` per scene.

Per scene seed (see :mod:`gmcpt.dataset.scenes`):

1. a 16-spp preview of the scene at exposure 1 picks the exposure that puts
   the 95th luminance percentile at a random level in [0.4, 1.2] (radiance is
   linear in the emitters, so this only rescales the lights);
2. the scene is rebuilt at that exposure, and everything below is rendered
   from it, exactly as the product would:
   - ``reference``: full frame, ``reference_spp`` samples in passes of
     ``pass_spp`` with seeds disjoint from the input's (``REFERENCE_SEED``);
   - the product's sparse frame at a rate drawn from ``rate_range`` (mask
     ``random``, 16 spp, seed = scene seed), via
     :func:`gmcpt.sampling.strategies.render_sparse_frame`: ``radiance``, ``mask``,
     ``variance`` and the feature buffers (``feature_spp`` primary rays a pixel);
   - the same call at rate 1 (``full_radiance``, ``full_variance``): every
     pixel traced with the same per-pixel estimator, so training can draw
     fresh masks at any rate; a traced pixel's value has the same
     distribution whichever mask selected it.

Reproducibility: everything in a file is a pure function of the seed and
the spec (measured with Mitsuba 3.9.1, llvm_ad_rgb): scenes load without
Mitsuba's shape merging, which otherwise reorders emitters from one load to
the next (see :func:`gmcpt.dataset.scenes.build_scene`). Files of
``data/procedural-v1`` built before that change hold equally valid samples
that differ bit-wise from a rebuild.

Version 2 renders the features with 4 primary rays a pixel, the product's
default since then (version 1: 1 ray). The features are the only change, and
they depend on nothing but the scene and its seed, so a build over version-1
files re-renders their features in place (:func:`upgrade_example`, about a
second a scene) instead of the whole scene. Version 3 changed the features
again (albedo only for BSDFs with a diffuse lobe, clipped to [0, 1], and the
``coverage`` buffer: see :func:`gmcpt.render.kernels.render_features`); older files are
upgraded the same way.

Files (:mod:`gmcpt.io.examples`) live in ``ROOT/<split>/<seed:07d>.npz`` with a ``meta`` JSON entry
(dataset version, seed, split, exposure, rate, settings, render seconds);
``ROOT/manifest.json`` records the :class:`DatasetSpec`. Building skips files
that already exist with the current version, so an interrupted build resumes
where it stopped. Splits draw seeds from disjoint ranges
(``SPLIT_SEED_BASE``), so no seed, hence no scene, is shared.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from ..frame import DEFAULT_FEATURE_SPP
from ..io.examples import ARRAY_KEYS, example_path, load_example, save_example
from ..seeds import DATASET_REFERENCE_SEED as REFERENCE_SEED, SEEDS_PER_SPLIT, SPLIT_SEED_BASE

DATASET_VERSION = 3
FEATURE_KEYS = ("albedo", "normal", "depth", "visibility", "coverage")
#: Arrays of files older than version 3 (which added ``coverage``).
VERSION_2_KEYS = ARRAY_KEYS[:-1]


@dataclass(frozen=True)
class SplitSpec:
    """One split: ``count`` scenes from seed ``SPLIT_SEED_BASE[name] + first``."""

    name: str
    count: int
    resolution: int = 128
    reference_spp: int = 512
    first: int = 0

    def seeds(self) -> list[int]:
        if self.name not in SPLIT_SEED_BASE:
            raise ValueError(f"unknown split {self.name!r}; choose from {', '.join(SPLIT_SEED_BASE)}")
        if self.first < 0 or self.count < 0 or self.first + self.count > SEEDS_PER_SPLIT:
            raise ValueError(f"split {self.name}: seeds must stay within {SEEDS_PER_SPLIT} of the split base")
        base = SPLIT_SEED_BASE[self.name]
        return list(range(base + self.first, base + self.first + self.count))


@dataclass(frozen=True)
class DatasetSpec:
    """Settings shared by all splits of a dataset build."""

    splits: tuple[SplitSpec, ...] = field(default_factory=lambda: (SplitSpec("train", 200), SplitSpec("val", 10)))
    spp: int = 16
    rate_range: tuple[float, float] = (0.15, 0.5)
    pass_spp: int = 128
    exposure_range: tuple[float, float] = (0.4, 1.2)
    feature_spp: int = DEFAULT_FEATURE_SPP
    version: int = DATASET_VERSION
    #: ``mixed``: procedural scenes (:mod:`gmcpt.dataset.scenes`); ``real``: views of the scene files
    #: ``real_files`` under ``real_root`` (:mod:`gmcpt.dataset.real`)
    layout: str = "mixed"
    real_root: str = ""
    real_files: tuple[str, ...] = ()

    def to_json(self) -> dict:
        return asdict(self)


def split_of(seed: int) -> str:
    """The split a seed belongs to."""
    for name, base in SPLIT_SEED_BASE.items():
        if base <= seed < base + SEEDS_PER_SPLIT:
            return name
    raise ValueError(f"seed {seed} is in no split")


def pick_exposure(seed: int, resolution: int, spec: DatasetSpec) -> float:
    """The emitter scale of scene ``seed`` (step 1 of the module docstring); deterministic."""
    import mitsuba as mi

    from .scenes import build_scene

    preview = np.asarray(mi.render(build_scene(seed, resolution, 1.0), spp=16,
                                   seed=REFERENCE_SEED - 1))[..., :3]
    level = float(np.percentile(np.nan_to_num(preview).mean(axis=-1), 95))
    target = np.random.default_rng([seed, 0xE7905]).uniform(*spec.exposure_range)
    return float(np.clip(target / max(level, 1e-6), 1e-2, 1e3))


def render_reference(scene, spp: int, pass_spp: int, seed: int) -> np.ndarray:
    """Full-frame mean of ``spp`` samples in passes with seeds disjoint from the input's."""
    import drjit as dr
    import mitsuba as mi

    passes = max(1, spp // pass_spp)
    total = None
    for index in range(passes):
        image = mi.render(scene, spp=min(pass_spp, spp), seed=REFERENCE_SEED + seed * 64 + index)
        dr.eval(image)
        array = np.nan_to_num(np.asarray(image, np.float64)[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
        total = array if total is None else total + array
    return (total / passes).astype(np.float32)


def render_frames(scene, seed: int, split: SplitSpec, spec: DatasetSpec):
    """``(reference, rate, frame, full)`` of a loaded scene: the reference, the product's sparse frame at a
    seeded rate and the same call at rate 1 (see the module docstring)."""
    from ..sampling.strategies import RenderSettings, render_sparse_frame

    reference = render_reference(scene, split.reference_spp, spec.pass_spp, seed)
    rate = float(np.random.default_rng([seed, 0x4A7E]).uniform(*spec.rate_range))
    settings = RenderSettings(rate=rate, pattern="random", spp=spec.spp, seed=seed, feature_spp=spec.feature_spp)
    frame, _ = render_sparse_frame(scene, scene.integrator(), settings=settings)
    full, _ = render_sparse_frame(scene, scene.integrator(), settings=replace(settings, rate=1.0))
    return reference, rate, frame, full


def example_arrays(reference: np.ndarray, frame, full, scale: float = 1.0) -> dict:
    """The stored arrays of one example; ``scale`` multiplies every radiance (its variance by ``scale**2``),
    exactly what scaling every emitter by it would render, since radiance is linear in the emitters."""
    gain, gain2 = np.float32(scale), np.float32(scale * scale)
    return {"reference": reference * gain, "radiance": frame.radiance * gain, "mask": frame.mask,
            "variance": frame.variance * gain2, "albedo": frame.albedo, "normal": frame.normal,
            "depth": frame.depth, "visibility": frame.visibility,
            "full_radiance": np.where(full.mask[..., None], full.radiance * gain, 0.0).astype(np.float32),
            "full_variance": full.variance * gain2, "coverage": frame.coverage}


def example_meta(seed: int, split: SplitSpec, spec: DatasetSpec, rate: float, full, start: float, **extra) -> dict:
    return {"version": spec.version, "seed": seed, "split": split.name, **extra, "rate": rate,
            "resolution": split.resolution, "spp": spec.spp, "feature_spp": spec.feature_spp,
            "reference_spp": split.reference_spp, "full_mask_fraction": full.rendered_fraction,
            "seconds": time.perf_counter() - start}


def _render_real_example(seed: int, split: SplitSpec, spec: DatasetSpec) -> dict:
    """One example of the ``real`` layout: a view (:func:`gmcpt.dataset.real.draw_view`) of one of the scene files,
    its light scaled to a drawn level."""
    from ..render.scene import load_scene
    from .real import draw_view

    start = time.perf_counter()
    view = draw_view(seed, spec.real_files, split.resolution, spec.exposure_range)
    scene = load_scene(Path(spec.real_root) / view.file, (view.side, view.side), edit=view.edit(split.resolution))
    reference, rate, frame, full = render_frames(scene, seed, split, spec)
    level = float(np.percentile(reference.mean(axis=-1), 95))
    scale = float(np.clip(view.target / max(level, 1e-6), 1e-3, 1e4))
    meta = example_meta(seed, split, spec, rate, full, start, scene=view.file, light_scale=scale, yaw=view.yaw,
                        pitch=view.pitch, film_side=view.side, crop_offset=list(view.offset))
    return {"arrays": example_arrays(reference, frame, full, scale), "meta": meta}


def render_example(seed: int, split: SplitSpec, spec: DatasetSpec) -> dict:
    """Render one scene's arrays and metadata (see the module docstring)."""
    if spec.layout == "real":
        return _render_real_example(seed, split, spec)
    from .scenes import build_scene

    start = time.perf_counter()
    exposure = pick_exposure(seed, split.resolution, spec)
    scene = build_scene(seed, split.resolution, exposure, spec.spp)
    reference, rate, frame, full = render_frames(scene, seed, split, spec)
    return {"arrays": example_arrays(reference, frame, full),
            "meta": example_meta(seed, split, spec, rate, full, start, exposure=exposure)}


def file_version(path: Path) -> int | None:
    """The dataset version of a readable example at ``path``; None if missing, truncated or foreign."""
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            version = json.loads(str(data["meta"]))["version"]
            return version if all(k in data for k in (ARRAY_KEYS if version >= 3 else VERSION_2_KEYS)) else None
    except Exception:
        return None


def is_complete(path: Path, version: int = DATASET_VERSION) -> bool:
    """True if ``path`` holds a readable example of ``version``."""
    return file_version(path) == version


def is_upgradable(version: int | None, spec: DatasetSpec) -> bool:
    """True if a file of ``version`` differs from ``spec``'s only in its features (see the module docstring)."""
    return version is not None and version < spec.version == DATASET_VERSION


def upgrade_example(path: Path, spec: DatasetSpec) -> dict:
    """Bring an older example to ``spec.version``: re-render its features at ``spec.feature_spp``.

    The scene is rebuilt from the seed and exposure in the file's metadata and only the
    feature pass runs (same seed as :func:`render_example` uses); every other array is kept.
    """
    from ..render.kernels import render_features
    from .scenes import build_scene

    start = time.perf_counter()
    example = load_example(path)
    meta = example.pop("meta")
    scene = build_scene(meta["seed"], meta["resolution"], meta["exposure"], meta["spp"])
    features = render_features(scene, scene.sensors()[0], spec.feature_spp, meta["seed"])
    example.update({key: features[key] for key in FEATURE_KEYS})
    meta.update(version=spec.version, feature_spp=spec.feature_spp, seconds=meta["seconds"] + time.perf_counter() - start)
    return {"arrays": example, "meta": meta}


def _update_manifest(path: Path, spec: DatasetSpec) -> None:
    """Record ``spec`` in the manifest, merging splits built by earlier calls."""
    record = spec.to_json()
    record["splits"] = {split["name"]: split for split in record["splits"]}
    if path.is_file():
        old = json.loads(path.read_text())
        if is_upgradable(old.get("version"), spec):  # upgraded in place (see upgrade_example)
            old.update(version=spec.version, feature_spp=spec.feature_spp)
        if old.get("layout", "mixed") != spec.layout:  # another scene set (or one this version no longer renders)
            raise ValueError(f"{path.parent} was built with the scene layout {old.get('layout', 'mixed')}; "
                             f"this build renders {spec.layout}")
        keys = ("version", "spp", "rate_range", "pass_spp", "exposure_range", "feature_spp")
        for key in keys + (("real_files",) if spec.layout == "real" else ()):
            if json.dumps(old.get(key)) != json.dumps(record[key]):
                raise ValueError(f"{path.parent} was built with {key} = {old.get(key)}, this build has {record[key]}")
        record["splits"] = {**old.get("splits", {}), **record["splits"]}
    path.write_text(json.dumps(record, indent=1))


def _init_worker(threads: int) -> None:
    import gmcpt  # noqa: F401  (variant, LLVM)
    import drjit as dr
    import mitsuba as mi
    mi.set_log_level(mi.LogLevel.Error)
    if threads:
        dr.set_thread_count(threads)


def _work(job) -> tuple[int, str, float]:
    root, seed, split, spec = job
    path = example_path(root, split.name, seed)
    start = time.perf_counter()
    if is_upgradable(file_version(path), spec):
        example = upgrade_example(path, spec)
    else:
        example = render_example(seed, split, spec)
    save_example(path, example)
    return seed, split.name, time.perf_counter() - start


def _ray_work(job_and_threads) -> tuple[int, str, float]:
    """One scene as a Ray task; a retry after a lost worker finds a finished file and keeps it."""
    job, threads = job_and_threads
    _init_worker(threads)
    root, seed, split, spec = job
    if is_complete(example_path(root, split.name, seed), spec.version):
        return seed, split.name, 0.0
    return _work(job)


def _results(jobs: list, workers: int, threads: int, ray: str | None, quiet: bool):
    """(seed, split, seconds) of each job as it finishes: here, in a process pool or as Ray tasks."""
    if ray is not None:
        from ..runtime.cluster import connected, default_gpus, run_tasks
        with connected(ray, quiet=quiet) as resources:  # Mitsuba renders on the CPU or the GPU the task holds
            yield from run_tasks(_ray_work, [(job, threads or 1) for job in jobs], cpus=threads or 1,
                                 gpus=default_gpus(resources))
    elif workers == 0:
        _init_worker(threads)
        yield from map(_work, jobs)
    else:
        import multiprocessing
        pool = multiprocessing.get_context("spawn").Pool(workers, _init_worker, (threads,))
        try:
            yield from pool.imap_unordered(_work, jobs)
        finally:
            pool.terminate()


def build(root: str | Path, spec: DatasetSpec, workers: int = 1, threads: int = 0,
          say=lambda message: print(message, file=sys.stderr, flush=True), ray: str | None = None,
          quiet: bool = False) -> dict:
    """Render every missing example of ``spec`` under ``root``; returns counts and seconds.

    ``workers`` processes (spawned) render one scene each at a time; 0 renders
    in this process. ``threads`` caps Dr.Jit's threads per worker (0: all).
    ``ray`` (an address, :mod:`gmcpt.runtime.cluster`) renders each scene as a Ray task
    instead, on ``threads`` CPUs (default 1); the files are the same bits.
    Progress goes to ``say`` as lines, or a bar on a terminal; ``quiet``: none.
    """
    from ..runtime.progress import Progress

    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    _update_manifest(root / "manifest.json", spec)
    jobs = [(str(root), seed, split, spec) for split in spec.splits for seed in split.seeds()
            if not is_complete(example_path(root, split.name, seed), spec.version)]
    total = sum(split.count for split in spec.splits)
    where = f"as Ray tasks ({ray})" if ray is not None else f"with {workers} worker(s)"
    if not quiet:
        say(f"dataset {root}: {total - len(jobs)}/{total} done, {len(jobs)} to render {where}")
    start, seconds = time.perf_counter(), 0.0
    with Progress(len(jobs), "dataset", unit="scene", say=say, quiet=quiet) as bar:
        for seed, split, sec in _results(jobs, workers, threads, ray, quiet):
            seconds += sec
            bar.update(note=f"{split} seed {seed} {sec:.1f}s")
    return {"rendered": len(jobs), "total": total, "render_seconds": seconds,
            "wall_seconds": time.perf_counter() - start}
