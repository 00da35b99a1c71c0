#!/usr/bin/env python3
"""Import Mitsuba 0.6 scenes of hchoi405/dppm-scenes (ports of public scenes) into Mitsuba 3.

    python scripts/import_scenes.py [--source DIR] [--out data/real-scenes] [--variants] [NAMES...]

For each NAME it writes ``OUT/NAME/scene.xml`` (``version="3.0.0"``), the meshes and textures that
scene references (hard-linked, or copied across file systems), and ``OUT/NAME/README.md`` with the
source, author and licence. The README contract: **every change the importer makes to a scene is
one line of its README** (a renamed, translated or dropped plugin or parameter, a substituted
``$variable``), identical changes counted on one line. ``--variants`` also writes
the source's ``NAME_rand_sceneN.xml`` as ``OUT/NAME/rand_sceneN.xml``, translated the same way.
``--drop-missing`` drops a shape whose mesh file is absent from the source (a partial snapshot) instead
of failing: meant for the training-only scenes (``TRAINING_NAMES``), never for evaluation ones.

Without ``--source`` the repository is cloned sparsely into ``data/dppm-scenes`` (only the named
folders). The folders ``classroom`` and ``staircase`` are held out for independent checks and are
refused. Errors are one ``error: ...`` line and exit status 2; a scene folder is built beside its
target and renamed into place, so a failure leaves nothing half-written.
"""
from __future__ import annotations

import argparse
import contextlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # its siblings, when run as a script or loaded by path
from mitsuba06 import SceneImportError, Changes, translate  # noqa: E402
from scene_sources import DEFAULT_NAMES, HELD_OUT, REPOSITORY, SCENES, TRAINING_NAMES  # noqa: E402,F401 (tests read them here)


# ---------------------------------------------------------------- files


def referenced_files(root: ET.Element, source: Path, changes: Changes, drop_missing: bool = False) -> list[str]:
    """The relative file names the scene reads; a texture outside the scene's folder becomes mid grey.

    The repository's shared texture pool is not used: it mixes in files of the held-out scenes.
    ``drop_missing``: a shape whose file is missing is removed (the mirror of the repository lacks
    its largest blobs) instead of failing the import.
    """
    names = []
    for parent in list(root.iter()):
        for node in list(parent):
            if node.tag != "string" or node.get("name") != "filename":
                continue
            name = os.path.normpath(node.get("value"))
            if name.startswith("..") or os.path.isabs(name):
                raise SceneImportError(f"{source} names a file outside its folder: {node.get('value')}")
            if (source / name).is_file():
                node.set("value", name)
                names.append(name)
            elif parent.tag == "texture" and parent.get("type") == "bitmap":
                kept = {key: parent.get(key) for key in ("name", "id") if parent.get(key)}
                parent.clear()
                parent.attrib.update(kept, type="uniform")
                parent.append(ET.Element("float", name="value", value="0.5"))
                changes.add(f"texture `{name}` is not in the scene's folder: replaced by a uniform 0.5")
            elif drop_missing and parent.tag == "shape" and (holder := _parents(root).get(parent)) is not None:
                holder.remove(parent)
                changes.add(f"shape file `{name}` is missing from the source snapshot: the shape was dropped")
            else:
                raise SceneImportError(f"{source} references {name}, which is missing")
    return names


def _parents(root: ET.Element) -> dict[ET.Element, ET.Element]:
    return {child: parent for parent in root.iter() for child in parent}


def link_or_copy(source: Path, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)  # another file system


def write_readme(folder: Path, name: str, lines: dict[str, list[str]]) -> None:
    info = SCENES[name]
    text = [f"# {name}: {info['title']}", "",
            f"- Author: {info['author']}",
            f"- Licence: {info['licence']}",
            f"- Source: {REPOSITORY} (folder `scenes/{name}`), {info['provenance']}",
            f"- Framing: {info['framing']}.",
            f"- As an evaluation scene: {info['notes']}." if "notes" in info else f"- {info['use']}.",
            "- Imported into Mitsuba 3 by gmcpt's `scripts/import_scenes.py`.", ""]
    for file, changes in lines.items():
        text += [f"## Changes in `{file}` (one line each)", ""] + [f"- {line}" for line in changes] + [""]
    (folder / "README.md").write_text("\n".join(text))


def import_scene(source_root: Path, out: Path, name: str, variants: bool, drop_missing: bool = False) -> Path:
    """Build ``out/name`` in a temporary folder beside it and rename it into place."""
    source = source_root / "scenes" / name
    if not (source / "scene.xml").is_file():
        raise SceneImportError(f"scene folder not found: {source} (no scene.xml)")
    files = [("scene.xml", source / "scene.xml")]
    if variants:
        files += [(f"rand_scene{m.group(1)}.xml", path) for path in sorted(source.glob(f"{name}_rand_scene*.xml"))
                  if (m := re.fullmatch(rf"{re.escape(name)}_rand_scene(\d+)\.xml", path.name))]
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        build = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=out))
    except OSError as error:
        raise SceneImportError(f"cannot write to {out}: {error.strerror}") from None
    done = False
    try:
        readme, assets = {}, set()
        for target, path in files:
            try:
                root = ET.parse(path).getroot()
            except ET.ParseError as error:
                raise SceneImportError(f"malformed XML {path}: {error}") from None
            changes = Changes()
            try:
                translate(root, changes)
            except (ValueError, AttributeError) as error:  # a malformed value in the source
                raise SceneImportError(f"cannot translate {path}: {error}") from None
            assets.update(referenced_files(root, source, changes, drop_missing))
            ET.indent(root, space="\t")
            ET.ElementTree(root).write(build / target, encoding="utf-8", xml_declaration=True)
            readme[target] = changes.lines()
        for asset in sorted(assets):
            link_or_copy(source / asset, build / asset)
        if (source / "LICENSE.txt").is_file():
            link_or_copy(source / "LICENSE.txt", build / "LICENSE.txt")
        write_readme(build, name, readme)
        final, old = out / name, build.with_name(build.name + ".old")
        if final.exists():
            final.rename(old)  # set aside, so that a failed rename below can be undone
        try:
            build.rename(final)
        except OSError:
            if old.exists():
                old.rename(final)
            raise
        shutil.rmtree(old, ignore_errors=True)
        done = True
        return final
    except OSError as error:
        raise SceneImportError(f"cannot write {out / name}: {error.strerror or error}") from None
    finally:
        shutil.rmtree(build, ignore_errors=True)
        if created and not done:
            with contextlib.suppress(OSError):
                out.rmdir()  # the folder this call made, empty again


def clone(target: Path, names: list[str]) -> Path:
    """A sparse, blob-less clone holding only ``scenes/NAME`` for the names asked (never the held-out ones)."""
    folders = [f"scenes/{name}" for name in names]
    if (target / ".git").is_dir():
        commands = [["git", "-C", str(target), "sparse-checkout", "add", *folders]]
    else:
        commands = [["git", "clone", "--quiet", "--filter=blob:none", "--sparse", REPOSITORY, str(target)],
                    ["git", "-C", str(target), "sparse-checkout", "set", *folders]]
    for command in commands:
        try:
            result = subprocess.run(command, capture_output=True, text=True)
        except OSError as error:
            raise SceneImportError(f"cannot run git to fetch {REPOSITORY}: {error.strerror}") from None
        if result.returncode != 0:
            reason = (result.stderr.strip().splitlines() or ["git failed"])[-1]
            raise SceneImportError(f"cannot fetch {REPOSITORY} (no network?): {reason}")
    return target


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"scenes (default: {' '.join(DEFAULT_NAMES)}; "
                        f"also: {' '.join(n for n in SCENES if n not in DEFAULT_NAMES)})")
    parser.add_argument("--source", type=Path,
                        help="a checkout of dppm-scenes (default: clone it into data/dppm-scenes)")
    parser.add_argument("--out", type=Path, default=ROOT / "data" / "real-scenes",
                        help="folder of the imported scenes (default: data/real-scenes, where the evaluation looks)")
    parser.add_argument("--variants", action="store_true", help="also import the *_rand_sceneN.xml variants")
    parser.add_argument("--drop-missing", action="store_true",
                        help="drop a shape whose mesh file the source lacks, not fail (training scenes only)")
    args = parser.parse_args(argv)
    names = args.names or list(DEFAULT_NAMES)
    try:
        for name in names:
            if name in HELD_OUT:
                raise SceneImportError(f"scene {name!r} is held out for independent checks and is never imported")
            if name not in SCENES:
                raise SceneImportError(f"unknown scene {name!r} (known: {', '.join(SCENES)})")
        source = args.source if args.source is not None else clone(ROOT / "data" / "dppm-scenes", names)
        if not source.is_dir():
            raise SceneImportError(f"source folder not found: {source}")
        for name in names:
            print(import_scene(source, args.out, name, args.variants, args.drop_missing) / "scene.xml")
    except SceneImportError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
