"""Load any Mitsuba 3 scene and put ``masked_path`` in charge of it."""
from __future__ import annotations

import contextlib
import xml.etree.ElementTree as ET
from pathlib import Path

import mitsuba as mi

from .errors import GmcptError


@contextlib.contextmanager
def _resolving_from(folder: Path):
    """Let Mitsuba resolve relative paths (meshes, textures) from ``folder``."""
    resolver = mi.file_resolver()
    saved = [str(entry) for entry in resolver]
    resolver.prepend(str(folder))
    try:
        yield
    finally:
        resolver.clear()
        for entry in saved:
            resolver.append(entry)


def _set_film_size(root: ET.Element, width: int, height: int) -> None:
    films = root.findall("./sensor/film")
    if not films:
        raise GmcptError("cannot set the resolution: the scene has no <sensor><film>")
    for film in films:
        for name, value in (("width", width), ("height", height)):
            node = film.find(f"integer[@name='{name}']")
            if node is None:
                node = ET.SubElement(film, "integer", name=name)
            node.set("value", str(value))


def _remove_elements(root: ET.Element, ids: tuple[str, ...], path: Path) -> None:
    found = {element.get("id"): element for element in root if element.get("id") in ids}
    missing = [name for name in ids if name not in found]
    if missing:
        raise GmcptError(f"{path} has no top-level element with id {', '.join(missing)}")
    for element in found.values():
        root.remove(element)


def load_scene(path: str | Path, resolution: tuple[int, int] | None = None,
               parameters: dict[str, str] | None = None, without: tuple[str, ...] = ()) -> mi.Scene:
    """Load a Mitsuba 3 XML scene, optionally at another resolution.

    Parameters
    ----------
    path : scene file; relative resources resolve from its folder.
    resolution : (width, height) replacing every sensor film's size.
    parameters : values for the scene's ``$name`` parameters (``<default>``).
    without : ids of top-level elements (shapes, emitters) to leave out.
    """
    path = Path(path)
    if not path.is_file():
        raise GmcptError(f"scene file not found: {path}")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise GmcptError(f"malformed scene XML {path}: {error}") from None
    if root.tag != "scene":
        raise GmcptError(f"{path} is not a Mitsuba scene (root element <{root.tag}>)")
    if resolution is not None:
        _set_film_size(root, *resolution)
    if without:
        _remove_elements(root, tuple(without), path)
    text = ET.tostring(root, encoding="unicode")
    try:
        with _resolving_from(path.resolve().parent):
            return mi.load_string(text, **(parameters or {}))
    except Exception as error:  # Mitsuba reports all load errors as RuntimeError
        message = " ".join(str(error).split())
        raise GmcptError(f"cannot load scene {path}: {message}") from None


def masked_integrator(scene: mi.Scene, **overrides) -> mi.Integrator:
    """The scene's ``masked_path`` integrator with ``overrides`` applied.

    A scene whose integrator is something else (e.g. ``path``) gets that
    integrator wrapped as the nested one, keeping its settings; a scene with
    no integrator gets the default ``path``. Overrides set to None are ignored.
    """
    from .completion import get_method
    from .plugins import require_plugin

    require_plugin("masked_path")
    current = scene.integrator()
    overrides = {key: value for key, value in overrides.items() if value is not None}
    if callable(getattr(current, "plugin_properties", None)):  # masked_path (its class lives in mitsuba_plugins)
        settings, nested = current.plugin_properties(), current.integrator
    else:
        settings, nested = {}, current
    settings.update(overrides)
    if "completion" in overrides and "weights" not in overrides and not get_method(settings["completion"]).takes("weights"):
        settings.pop("weights", None)  # a scene's GAN weights do not follow to a method that has none
    description = {"type": "masked_path", **{key: value for key, value in settings.items() if value is not None}}
    if nested is not None:
        description["integrator"] = nested
    return mi.load_dict(description)
