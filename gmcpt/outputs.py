"""Write a completed render: multi-layer EXR, sRGB PNG preview, JSON record.

``write_outputs`` writes all three to temporary names and renames them only
once every one is complete.
"""
from __future__ import annotations

import contextlib
import json
import platform
from importlib import metadata
from pathlib import Path

import numpy as np

from .frame import SparseFrame
from .exr import atomic_output, channel_names, pack, write_exr, write_png

VERSIONED = ("gmcpt", "mitsuba", "drjit", "torch", "numpy", "OpenEXR", "colour-science", "scikit-image")


def library_versions() -> dict[str, str]:
    versions = {"python": platform.python_version()}
    for package in VERSIONED:
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "not installed"
    return versions


def sidecar_paths(out: str | Path) -> tuple[Path, Path, Path]:
    """(EXR, PNG, JSON) paths for an output named ``out`` (``X.exr``)."""
    out = Path(out)
    return out, out.with_suffix(".png"), out.with_suffix(".json")


def write_outputs(out: str | Path, frame: SparseFrame, image: np.ndarray, record: dict) -> list[Path]:
    """Write ``out`` (EXR), its PNG preview and JSON ``record``, atomically."""
    exr_path, png_path, json_path = sidecar_paths(out)
    tensor = pack(frame, image)
    channels = {name: tensor[..., index] for index, name in enumerate(channel_names())}
    with contextlib.ExitStack() as stack:
        exr_tmp, png_tmp, json_tmp = (stack.enter_context(atomic_output(p)) for p in (exr_path, png_path, json_path))
        write_exr(exr_tmp, channels, {"gmcpt": json.dumps(record.get("parameters", {}))})
        write_png(png_tmp, image)
        Path(json_tmp).write_text(json.dumps(record, indent=2, default=_jsonable) + "\n")
    return [exr_path, png_path, json_path]


def _jsonable(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"cannot serialise {type(value).__name__}")
