"""Load any Mitsuba 3 scene and put ``masked_path`` in charge of it."""
from __future__ import annotations

import contextlib
from collections.abc import Callable
import xml.etree.ElementTree as ET
from pathlib import Path

import mitsuba as mi
import numpy as np

from ..errors import GmcptError
from ..runtime.plugins import mitsuba_message, plugin_errors


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


def _resolve(name: str, folders: tuple[Path, ...]) -> Path | None:
    """The file ``name`` names, looked up as Mitsuba does: absolute, else in ``folders`` in order."""
    if not name or "$" in name:
        return None
    if Path(name).is_absolute():
        return Path(name)
    return next((folder / name for folder in folders if (folder / name).is_file()), None)


def _inline_includes(root: ET.Element, folders: tuple[Path, ...], depth: int = 0) -> list[Path]:
    """Replace each ``<include filename=...>`` by the children of the file it names; returns the files included.

    As in Mitsuba, a relative name resolves from the including file's folder, then the scene's; the
    included files' own relative file names are made absolute, so they still resolve once inlined.
    """
    included_files = []
    for parent in list(root.iter()):
        for index, child in reversed(list(enumerate(parent))):
            path = _resolve(child.get("filename", ""), folders) if child.tag == "include" else None
            if path is None or not path.is_file() or depth > 16:
                continue  # not an include, or one Mitsuba reports while loading
            try:
                included = ET.parse(path).getroot()
            except ET.ParseError as error:
                raise GmcptError(f"malformed included XML {path}: {error}") from None
            inner = (path.resolve().parent, *folders)
            for node in included.iter("string"):
                name = _resolve(node.get("value", ""), inner[:1]) if node.get("name") == "filename" else None
                if name is not None:
                    node.set("value", str(name))
            included_files += [path, *_inline_includes(included, inner, depth + 1)]
            parent.remove(child)
            for offset, element in enumerate(included):
                parent.insert(index + offset, element)
    return included_files


@contextlib.contextmanager
def _loading_threads():
    """At least two Dr.Jit threads while Mitsuba loads a scene: with one (``dr.set_thread_count(1)``, as
    ``--threads 1`` sets), reading an EXR file (an environment map, a texture) never returns: OpenEXR's
    reader waits on work the single pool thread cannot take (Mitsuba 3.9.1, living-room's envmap)."""
    import drjit as dr

    count = dr.thread_count()
    if count >= 2:
        yield
        return
    dr.set_thread_count(2)
    try:
        yield
    finally:
        dr.set_thread_count(count)


def _set_film_size(root: ET.Element, width: int, height: int) -> None:
    for sensor in root.findall("./sensor"):
        film = sensor.find("film")
        if film is None:  # the default film, made explicit to set its size
            film = ET.SubElement(sensor, "film", type="hdrfilm")
        for name, value in (("width", width), ("height", height)):
            node = film.find(f"integer[@name='{name}']")
            if node is None:
                node = ET.SubElement(film, "integer", name=name)
            node.set("value", str(value))


def _no_sensor(path: Path) -> GmcptError:
    return GmcptError(f"scene {path} has no <sensor> (a camera) to render from")


def scene_sensor(scene: mi.Scene, index: int = 0, path: str | Path | None = None) -> mi.Sensor:
    """Sensor ``index`` of ``scene``; a one-line :class:`GmcptError` when the scene has no such sensor."""
    sensors = scene.sensors()
    if not sensors:
        raise _no_sensor(path or "(loaded)")
    if not -len(sensors) <= index < len(sensors):
        raise GmcptError(f"the scene has {len(sensors)} sensor(s), there is no sensor {index}")
    return sensors[index]


#: The path tracer of a scene without an integrator (``masked_path`` nests it where it is given none).
DEFAULT_PATH = {"type": "path", "max_depth": 8, "rr_depth": 5}


def path_integrator(scene: mi.Scene) -> mi.SamplingIntegrator:
    """The scene's own integrator, or the one ``masked_path`` wraps: the path tracer every pass traces with;
    :data:`DEFAULT_PATH` for a scene without one (the same object on every call: frozen kernels record once an
    integrator)."""
    from .held import scene_state

    integrator = scene.integrator()
    if integrator is None:
        state = scene_state(scene)
        if "default integrator" not in state:
            state["default integrator"] = mi.load_dict(DEFAULT_PATH)
        return state["default integrator"]
    return getattr(integrator, "integrator", integrator)


def check_scene_file(path: str | Path) -> Path:
    """``path`` if it is a file; else one line: a folder (and its ``scene.xml``, if it has one), or not found."""
    path = Path(path)
    if path.is_dir():
        inside = path / "scene.xml"
        hint = f", e.g. {inside}" if inside.is_file() else ""
        raise GmcptError(f"{path} is a folder, not a scene file; give the scene's XML file{hint}")
    if not path.is_file():
        raise GmcptError(f"scene file not found: {path}")
    return path


def check_animated(path: str | Path) -> Path:
    """``path`` if its scene reads ``$frame`` somewhere (itself or a file it includes); else one line.

    ``--frames A:B`` loads the scene with ``frame=A, ..., B-1``: Mitsuba refuses a parameter nothing reads
    ("Found unused parameters"), and this says so before any work, in the words of ``--frames``. Declaring
    ``<default name="frame" value="0"/>`` alone animates nothing; reading ``$frame`` without a default works
    (``--frames`` passes it)."""
    import re

    path = check_scene_file(path)
    try:
        root = ET.parse(path).getroot()
        _inline_includes(root, (path.resolve().parent,))
    except (OSError, ET.ParseError, GmcptError):
        return path  # load_scene says what is wrong with it
    reads = re.compile(r"\$frame\b")
    if not any(reads.search(value) for element in root.iter() for value in element.attrib.values()):
        raise GmcptError(f"{path} has no animation for --frames: nothing in it reads $frame (e.g. "
                         f'<default name="frame" value="0"/> and <rotate y="1" angle="$frame"/> in the camera)')
    return path


def scene_inputs(path: str | Path) -> list[Path]:
    """The files a scene reads: itself, the files it includes and the files it names (meshes, textures)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
        files = [path, *_inline_includes(root, (path.resolve().parent,))]
    except (OSError, ET.ParseError, GmcptError):
        return [path]  # load_scene says what is wrong with it
    for node in root.iter("string"):
        name = node.get("value", "") if node.get("name") == "filename" else ""
        if name and "$" not in name:
            files.append(path.resolve().parent / name)  # an absolute name stays as it is
    return files


def _remove_elements(root: ET.Element, ids: tuple[str, ...], path: Path) -> None:
    found = {element.get("id"): element for element in root if element.get("id") in ids}
    missing = [name for name in ids if name not in found]
    if missing:
        raise GmcptError(f"{path} has no top-level element with id {', '.join(missing)}")
    for element in found.values():
        root.remove(element)


def load_scene(path: str | Path, resolution: tuple[int, int] | None = None,
               parameters: dict[str, str] | None = None, without: tuple[str, ...] = (),
               edit: Callable[[ET.Element], None] | None = None) -> mi.Scene:
    """Load a Mitsuba 3 XML scene, optionally at another resolution.

    Parameters
    ----------
    path : scene file; relative resources resolve from its folder.
    resolution : (width, height) replacing every sensor film's size.
    parameters : values for the scene's ``$name`` parameters (``<default>``).
    without : ids of top-level elements (shapes, emitters) to leave out.
    edit : called with the parsed ``<scene>`` (includes inlined) last, to change it before loading
        (e.g. the dataset's camera jitter, :mod:`gmcpt.dataset.real`).
    """
    path = check_scene_file(path)
    return load_tree(scene_tree(path, resolution, without, edit), path, parameters)


def scene_tree(path: Path, resolution: tuple[int, int] | None = None, without: tuple[str, ...] = (),
               edit: Callable[[ET.Element], None] | None = None) -> ET.Element:
    """The ``<scene>`` element :func:`load_scene` loads from ``path`` (an existing file): includes inlined where it
    changes the scene (``resolution``, ``without``, ``edit``), one line for malformed XML or no sensor."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as error:
        raise GmcptError(f"malformed scene XML {path}: {error}") from None
    if root.tag != "scene":
        raise GmcptError(f"{path} is not a Mitsuba scene (root element <{root.tag}>)")
    if resolution is not None or without or edit is not None:
        _inline_includes(root, (path.resolve().parent,))
        if not root.findall("./sensor"):
            raise _no_sensor(path)
    if resolution is not None:
        _set_film_size(root, *resolution)
    if without:
        _remove_elements(root, tuple(without), path)
    if edit is not None:
        edit(root)
    return root


def load_tree(root: ET.Element, path: Path, parameters: dict[str, str] | None = None, whole: bool = True) -> mi.Scene:
    """The scene of ``root`` (a ``<scene>`` element of the file ``path``: relative names resolve from its folder),
    its normals settled; ``whole``: it must have a sensor (a part of a scene, loaded to read its objects, need not)."""
    text = ET.tostring(root, encoding="unicode")
    try:
        with _resolving_from(path.resolve().parent), plugin_errors(f"cannot load scene {path}: "), _loading_threads():
            # without shape merging: merging orders the merged shapes, and with them the area emitters, anew on
            # every load, so emitter sampling (every sample) changed between processes (docs/experiments.md)
            scene = mi.load_string(text, optimize=False, **(parameters or {}))
    except GmcptError:
        raise
    except Exception as error:  # Mitsuba reports all load errors as RuntimeError
        raise GmcptError(f"cannot load scene {path}: {mitsuba_message(error)}") from None
    if whole:
        scene_sensor(scene, path=path)
    settle_normals(scene)
    return scene


#: How far (any component) a mesh's loaded normals may be from the smooth ones summed again and still be taken for
#: Mitsuba's own: rounding moves them by about 1e-7; a file's normals that differ do so by far more
SMOOTH_NORMALS_TOLERANCE = 1e-4


def settle_normals(scene: mi.Scene) -> None:
    """Give every mesh whose vertex normals Mitsuba computed at load (its file had none) the same normals on every
    load, once a scene (``load_scene`` does it, and ``masked_path`` at a scene's first render: a scene the user
    loaded). Mitsuba sums them over faces with float atomics on all its threads, in another order each time: other
    bits, and with them other images (docs/experiments.md, sixty-seventh session). Summed again on one thread they
    are a function of the mesh alone. A mesh whose file gave its normals keeps them."""
    import drjit as dr

    from .held import scene_state

    state = scene_state(scene)
    if state.get("normals settled") or not mi.variant().startswith("llvm"):
        return  # on a GPU the atomics' order is the GPU's, one thread or many on the CPU
    state["normals settled"] = True
    meshes = [shape for shape in scene.shapes() if isinstance(shape, mi.Mesh) and shape.has_vertex_normals()]
    if not meshes:
        return
    threads = dr.thread_count()
    dr.set_thread_count(1)
    try:
        for mesh in meshes:
            parameters = mi.traverse(mesh)
            if "vertex_normals" not in parameters.properties:
                continue  # a shape Mitsuba makes a mesh of (a rectangle): normals of its own, not summed
            loaded = np.array(mesh.vertex_normals_buffer())
            mesh.recompute_vertex_normals()
            if np.abs(np.array(mesh.vertex_normals_buffer()) - loaded).max(initial=0.0) > SMOOTH_NORMALS_TOLERANCE:
                parameters["vertex_normals"] = mi.Float(loaded)  # the file's
                parameters.update()
    finally:
        dr.set_thread_count(threads)


def masked_integrator(scene: mi.Scene, **overrides) -> mi.Integrator:
    """The scene's ``masked_path`` integrator with ``overrides`` applied.

    A scene whose integrator is something else (e.g. ``path``) gets that
    integrator wrapped as the nested one, keeping its settings; a scene with
    no integrator gets the default ``path``. Overrides set to None are ignored.
    """
    from ..completion import get_method
    from ..runtime.plugins import require_plugin

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
    with plugin_errors():
        return mi.load_dict(description)
