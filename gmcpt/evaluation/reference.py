"""High-spp reference renders, cached on disk.

A reference is the scene's own integrator (the nested one, for scenes that name
``masked_path``) run full frame at many spp, in passes of ``pass_spp`` with
independent seeds, averaged. The cache key covers the scene file's bytes, the
resolution, spp, seed and scene parameters, so an edited scene is re-rendered.
Cache folder: ``$GMCPT_CACHE`` or ``~/.cache/gmcpt/references``. A render that stops
(Ctrl-C, a lost session) resumes after its last finished pass: the passes' sum is kept
beside the cache entry (``KEY.partial.npz``) until the reference is written.
"""
from __future__ import annotations

import contextlib

import hashlib
import json
import zipfile
from pathlib import Path
from typing import Callable

import numpy as np

from ..io.exr import atomic_output, read_rgb_exr, write_exr
from ..io.files import cache_folder
from ..seeds import REFERENCE_FIRST_SEED


def cache_dir() -> Path:
    return cache_folder("references")


def film_size(resolution: int | tuple[int, int]) -> tuple[int, int]:
    """(W, H) of a square side or a (W, H) pair."""
    return (resolution, resolution) if isinstance(resolution, int) else tuple(resolution)


def reference_key(scene_path: str | Path, resolution: int | tuple[int, int], spp: int, seed: int,
                  parameters: dict | None = None, without: tuple[str, ...] = ()) -> str:
    digest = hashlib.sha256(Path(scene_path).read_bytes())
    key = [resolution if isinstance(resolution, int) else list(resolution), spp, seed,
           sorted((parameters or {}).items())]
    if without:  # keys of references made before this option stay valid
        key.append(sorted(without))
    digest.update(json.dumps(key).encode())
    size = resolution if isinstance(resolution, int) else "x".join(map(str, resolution))
    return f"{Path(scene_path).parent.name}-{size}px-{spp}spp-s{seed}-{digest.hexdigest()[:12]}"


def render_reference(scene_path: str | Path, resolution: int | tuple[int, int] = 256, spp: int = 4096,
                     seed: int = REFERENCE_FIRST_SEED, parameters: dict | None = None, pass_spp: int = 256,
                     progress: Callable[[str], None] | None = None, without: tuple[str, ...] = (),
                     folder: Path | None = None) -> np.ndarray:
    """Return a cached (H, W, 3) reference of a scene file, rendering it on a miss.

    ``resolution``: a square side or (W, H). ``without`` lists ids of scene elements left out (see
    :func:`gmcpt.render.scene.load_scene`). ``folder``: where the cache is (default :func:`cache_dir`).
    """
    from ..render.scene import load_scene

    key = reference_key(scene_path, resolution, spp, seed, parameters, without)
    return cached_reference(key, lambda: load_scene(scene_path, film_size(resolution), parameters, without),
                            spp, seed, pass_spp, progress, label=Path(scene_path).parent.name, folder=folder)


_cached_only = {"on": False}


@contextlib.contextmanager
def cached_only():
    """Within it, a reference missing from the cache raises LookupError instead of being rendered (benchmarks
    that measure against the evaluation's references, without its hours of rendering)."""
    _cached_only["on"] = True
    try:
        yield
    finally:
        _cached_only["on"] = False


def cached_reference(key: str, load: Callable[[], object], spp: int, seed: int, pass_spp: int = 256,
                     progress: Callable[[str], None] | None = None, label: str = "",
                     folder: Path | None = None) -> np.ndarray:
    """The reference stored under ``key`` in ``folder`` (default :func:`cache_dir`), or render it from ``load()``
    and store it.

    The scene's own integrator (unwrapped from ``masked_path``) runs full frame
    in passes of ``pass_spp`` samples with seeds ``seed, seed + 1, ...``; the
    passes are averaged in float64 (:func:`render_full`). Written atomically.
    """
    path = (folder or cache_dir()) / (key + ".exr")
    if path.is_file():
        return read_rgb_exr(path)
    if _cached_only["on"]:
        raise LookupError(f"no cached reference {path}")
    path.parent.mkdir(parents=True, exist_ok=True)
    checkpoint = path.with_name(key + ".partial.npz")
    reference = render_full(load(), spp, seed, pass_spp, progress, label or key, checkpoint)
    with atomic_output(path) as temporary:
        write_exr(temporary, {c: reference[..., i] for i, c in enumerate("RGB")},
                  {"spp": max(1, spp // pass_spp) * min(pass_spp, spp), "scene": label or key})
    checkpoint.unlink(missing_ok=True)
    return reference


def render_full(scene, spp: int, seed: int, pass_spp: int = 256, progress: Callable[[str], None] | None = None,
                label: str = "", checkpoint: Path | None = None) -> np.ndarray:
    """(H, W, 3) float32: the scene's own integrator (unwrapped from ``masked_path``), full frame.

    ``spp`` samples in passes of ``pass_spp`` with seeds ``seed, seed + 1, ...``, averaged in float64.
    ``checkpoint``: a file that holds the sum of the finished passes after each one, and from which a render of the
    same settings resumes (the same image to the bit as one run through); the caller removes it.
    """
    import drjit as dr
    import mitsuba as mi

    from ..render.scene import path_integrator

    integrator = path_integrator(scene)
    passes = max(1, spp // pass_spp)
    done, total = _resumed(checkpoint, passes)
    for index in range(passes):
        if progress:
            progress(f"reference {label}: pass {index + 1}/{passes}"
                     + (" (kept from an interrupted render)" if index < done else ""))
        if index < done:
            continue
        image = mi.render(scene, integrator=integrator, spp=min(pass_spp, spp), seed=seed + index)
        dr.eval(image)
        array = np.asarray(image, dtype=np.float64)[..., :3]
        total = array if total is None else total + array
        if checkpoint is not None and index + 1 < passes:
            with atomic_output(checkpoint) as temporary, open(temporary, "wb") as file:
                np.savez(file, total=total, passes=index + 1)
    return (total / passes).astype(np.float32)


def _resumed(checkpoint: Path | None, passes: int) -> tuple[int, np.ndarray | None]:
    """(passes finished, their float64 sum) from ``checkpoint``; (0, None) where there is none to trust (a damaged
    file renders again from the first pass)."""
    if checkpoint is None or not checkpoint.is_file():
        return 0, None
    try:
        with np.load(checkpoint) as saved:
            done, total = int(saved["passes"]), saved["total"]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return 0, None
    if not 0 < done < passes or total.dtype != np.float64 or total.ndim != 3:
        return 0, None
    return done, total
