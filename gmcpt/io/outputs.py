"""Write a completed render: multi-layer EXR, sRGB PNG preview, JSON record.

``write_outputs`` writes all three to temporary names and renames them only
once every one is complete, as one set (:func:`gmcpt.io.files.write_together`):
a failure leaves the previous outputs, if any, as they were.
"""
from __future__ import annotations

import platform
from importlib import metadata
from pathlib import Path
from typing import Callable

import numpy as np

from ..frame import SparseFrame
from .exr import named_channels, pack, write_exr, write_png
from .files import json_text, write_together

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


def write_outputs(out: str | Path, frame: SparseFrame, image: np.ndarray, record: dict,
                  committed: Callable[[], None] | None = None) -> list[Path]:
    """Write ``out`` (EXR), its PNG preview and JSON ``record`` (strict JSON: NaN/Inf as null), as one set;
    ``committed`` runs once all three are in place (:func:`gmcpt.io.files.write_together`)."""
    exr_path, png_path, json_path = sidecar_paths(out)
    channels = named_channels(pack(frame, image))
    attributes = {"gmcpt": json_text(record.get("parameters", {}), indent=None)}
    text = json_text(record)
    return write_together([(exr_path, lambda path: write_exr(path, channels, attributes)),
                           (png_path, lambda path: write_png(path, image)),
                           (json_path, lambda path: Path(path).write_text(text))], committed)
