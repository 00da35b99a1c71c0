"""Which file a generator weights name means (the shipped ones by name, any other ``.pt`` by path), and the
checks of a weights file that need no network: it exists, and its bytes match the sha256 its record holds.

Kept apart from :mod:`gmcpt.gan.weights`, which imports torch (6-7 s on 2 cores): a command line names its
weights file, and checking it must not wait for torch; nor does a CPU completion whose network is already
converted (:mod:`gmcpt.gan.runtime`).
"""
from __future__ import annotations

import functools
import hashlib
import json
import shlex
from pathlib import Path

from ..errors import GmcptError

WEIGHTS_DIR = Path(__file__).resolve().parent / "weights"
DEFAULT_WEIGHTS = "gan-cpu"


def weights_path(name_or_path: str | Path | None = None) -> Path:
    """A shipped weights name (``gan-cpu``) or a path to a ``.pt`` file."""
    name_or_path = name_or_path or DEFAULT_WEIGHTS
    path = Path(name_or_path)
    if path.suffix == ".pt" or path.parent != Path("."):
        return path
    return WEIGHTS_DIR / f"{name_or_path}.pt"


RETRAIN_HINT = "retrain with `python -m gmcpt train --config cpu --export {name}` (see README, 'GAN pre-completion: data, training, weights')"


def retrain_hint(path: Path) -> str:
    """How to make ``path`` again: a shipped file by its name, any other by its path."""
    return RETRAIN_HINT.format(name=path.stem if path.parent == WEIGHTS_DIR else shlex.quote(str(path)))


def sha256(path: str | Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def weights_record(path: Path) -> dict:
    """The record beside a weights file (``NAME.json``), {} if there is none; one line if it is unreadable."""
    meta_path = path.with_suffix(".json")
    if not meta_path.is_file():
        return {}
    try:
        metadata = json.loads(meta_path.read_text())
        problem = None if isinstance(metadata, dict) else "is not a JSON object"
    except (OSError, UnicodeDecodeError, ValueError) as error:
        problem = f"is not readable JSON ({getattr(error, 'strerror', None) or ' '.join(str(error).split())})"
    if problem:
        raise GmcptError(f"the record of GAN weights {meta_path} {problem}; restore it, or remove it to load "
                         f"{path.name} without its sha256 check; {retrain_hint(path)}")
    return metadata


def checked_weights(name_or_path: str | Path | None = None, check_hash: bool = True) -> tuple[Path, dict, str]:
    """(path, record, sha256) of a weights file that exists and, with ``check_hash``, matches the sha256 its record
    holds; a one-line :class:`GmcptError`, saying how to retrain, otherwise. Whether torch can load it is
    :func:`gmcpt.gan.weights.load_generator`'s to say."""
    path = weights_path(name_or_path)
    if not path.is_file():
        shipped = ", ".join(sorted(p.stem for p in WEIGHTS_DIR.glob("*.pt")))
        raise GmcptError(f"GAN weights not found: {path} (the shipped ones: {shipped}); {retrain_hint(path)}")
    stat = path.stat()
    metadata = weights_record(path)
    digest = _sha256_of(str(path.resolve()), stat.st_mtime_ns, stat.st_size)
    if check_hash and metadata.get("sha256") and metadata["sha256"] != digest:
        raise GmcptError(f"GAN weights {path} do not match the sha256 in {path.with_suffix('.json').name} "
                         f"(corrupt or replaced); {retrain_hint(path)}")
    return path, metadata, digest


@functools.lru_cache(maxsize=16)
def _sha256_of(path: str, modified_ns: int, size: int) -> str:
    """:func:`sha256` of a file, once per version of it in a process (a frame's completion asks again)."""
    return sha256(path)
