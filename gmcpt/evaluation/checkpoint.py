"""A long evaluation's progress on disk, so that a run stopped after hours resumes where it stood.

The quick evaluation takes close to three hours on two cores; the record of every finished scene is written to
``results.partial.json`` in the output folder and read back by the next run with the same configuration, scenes
and code (committed, its folders' git trees). A run on uncommitted code never resumes: its measurements could not
be traced to one version.
"""
from __future__ import annotations

import json
import subprocess
from dataclasses import asdict
from pathlib import Path

from ..io.files import atomic_output

PARTIAL = "results.partial.json"
#: the folders whose changes make a checkpoint stale (the output folder, often docs/, changes during a run)
CODE = ("gmcpt", "mitsuba_plugins", "scenes")


def code_version(root: Path) -> str | None:
    """The committed trees of ``root``'s code folders (a commit of documents alone keeps them), None where the
    code has uncommitted changes or there is no git."""
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", *(f"HEAD:{folder}" for folder in CODE)],
                              capture_output=True, text=True, timeout=10)
        changed = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no", "--",
                                  *CODE], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    if head.returncode or changed.returncode or changed.stdout.strip():
        return None
    return " ".join(head.stdout.split()) or None


def resume_key(config, scenes, version: str | None) -> dict | None:
    """What a checkpoint must match to be resumed, as it reads back from JSON; None: never checkpoint."""
    if version is None:
        return None
    key = {"config": asdict(config), "scenes": [scene.name for scene in scenes], "code": version}
    return json.loads(json.dumps(key, default=float))


def load(out: Path, key: dict | None) -> dict | None:
    """The record saved by an interrupted run with the same ``key``, else None."""
    path = out / PARTIAL
    if key is None or not path.is_file():
        return None
    try:
        saved = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return saved.get("record") if isinstance(saved, dict) and saved.get("key") == key else None


def save(out: Path, key: dict | None, record: dict) -> None:
    """Write ``record`` as the checkpoint (whole or not at all)."""
    if key is None:
        return
    with atomic_output(out / PARTIAL) as temporary:
        Path(temporary).write_text(json.dumps({"key": key, "record": record}, default=float))


def discard(out: Path) -> None:
    (out / PARTIAL).unlink(missing_ok=True)
