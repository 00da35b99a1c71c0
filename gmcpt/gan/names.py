"""Which file a generator weights name means: the shipped ones by name, any other ``.pt`` by path.

Kept apart from :mod:`gmcpt.gan.weights`, which loads torch (about 2 s): a command line names its weights
file, and checking it must not wait for torch.
"""
from __future__ import annotations

from pathlib import Path

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
DEFAULT_WEIGHTS = "gan-cpu"


def weights_path(name_or_path: str | Path | None = None) -> Path:
    """A shipped weights name (``gan-cpu``) or a path to a ``.pt`` file."""
    name_or_path = name_or_path or DEFAULT_WEIGHTS
    path = Path(name_or_path)
    if path.suffix == ".pt" or path.parent != Path("."):
        return path
    return WEIGHTS_DIR / f"{name_or_path}.pt"
