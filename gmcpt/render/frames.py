"""A scene file's frames as one held scene: a frame sets, through ``mi.traverse``, what its ``$`` parameters change.

A frame of an animation (``gmcpt batch SCENE --frames A:B``) differs from the frame before only in the elements of
the file that read a parameter whose value changed (``$frame``), or, written one file a frame, in the elements whose
XML differs from the file before's. :class:`SceneFrames` loads those top-level elements alone (a camera, a few
meshes, a light: milliseconds, where loading a room of 180 meshes takes 0.4-0.7 s) and sets their parameters on the
scene it holds, made opaque, so that the kernels compiled and recorded for the first frame serve the next ones.
An element that only moves (an environment map that turns) reads its ``to_world`` from a rectangle's, once that
was checked to be its own.
Where a change is not one ``mi.traverse`` can set, the frame's scene is loaded whole, as it was before: a parameter
read by an ``<integer>``, a ``<boolean>`` or a ``<string>`` other than a mesh's file, by an element other than a
sensor, shape, emitter, BSDF or texture (an integrator, a medium), a change of structure, a mesh whose file has
another number of vertices, or a changed property whose parameter ``mi.traverse`` does not list. The frames are the
images loading each one whole gives (``tests/test_sequence_batch.py``).
"""
from __future__ import annotations

import copy
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mitsuba as mi
import numpy as np

from .scene import check_scene_file, load_tree, scene_tree

#: The top-level elements whose changes a frame may set instead of loading the scene again.
SETTABLE_ELEMENTS = ("sensor", "shape", "emitter", "bsdf", "texture")
#: Properties whose ``value`` a frame may change (each must show as a changed ``mi.traverse`` parameter).
VALUE_TAGS = ("float", "rgb", "spectrum", "point", "vector")
#: Shapes whose ``filename`` a frame may change: their vertices, normals and faces are parameters.
MESH_TYPES = ("obj", "ply", "serialized")
#: An XML property's name where ``mi.traverse`` names its parameter otherwise.
TRAVERSE_NAMES = {"fov": "x_fov"}
#: The ids given to top-level elements that have none, so that their parameters keep their names from load to load
#: (Mitsuba names an object without an id by its address).
ID_PREFIX = "gmcpt-element-"


@dataclass(frozen=True)
class _File:
    """A scene file as :class:`SceneFrames` reads it: its ``<scene>`` (top-level elements named, the size set), its
    defaults, and its other top-level elements with their attributes' text (what they read)."""

    path: Path
    root: ET.Element
    defaults: dict
    texts: list

    @classmethod
    def read(cls, path: str | Path, resolution: tuple[int, int] | None) -> "_File":
        path = check_scene_file(path)
        root = scene_tree(path, resolution, edit=name_elements)
        return cls(path, root, {element.get("name"): element.get("value") for element in root.findall("default")},
                   [(element, _attribute_text(element)) for element in root if element.tag != "default"])


class SceneFrames:
    """The frames of the scene file ``path`` at ``resolution`` ((width, height), None: the file's): :meth:`at` gives
    the scene with a frame's ``$`` parameters (or another file of the animation), the same :class:`mitsuba.Scene`
    from frame to frame wherever the change can be set. ``loads`` counts the frames loaded whole, ``whole_reason``
    says why the last one after the first was."""

    def __init__(self, path: str | Path, resolution: tuple[int, int] | None = None):
        self.resolution = resolution
        self.file = _File.read(path, resolution)
        self.scene: mi.Scene | None = None
        self.values: dict[str, str] = {}
        self.loads, self.whole_reason = 0, ""
        #: element id -> whether its moves are read from a proxy's transform (checked at its first move: _loaded)
        self.proxies: dict[str, bool] = {}

    @property
    def path(self) -> Path:
        return self.file.path

    def at(self, parameters: dict[str, str], path: str | Path | None = None) -> mi.Scene:
        """The scene with ``parameters`` (``$name`` values; the file's ``<default>`` s for the others), of the file
        ``path`` where given: a frame of an animation written as one file a frame, whose elements are compared with
        the held file's (the same elements in the same order, else it is loaded whole)."""
        file = self.file if path is None or check_scene_file(path).resolve() == self.path.resolve() \
            else _File.read(path, self.resolution)
        values = {**file.defaults, **parameters}
        if self.scene is not None:
            try:
                self._set(file, values, parameters)
                self.file, self.values = file, values
                return self.scene
            except _Whole as whole:
                self.whole_reason = str(whole)
        self.scene, self.file, self.values = load_tree(file.root, file.path, parameters), file, values
        self.loads += 1
        self._settle([element for element, _ in file.texts if element.tag in SETTABLE_ELEMENTS])
        return self.scene

    def _settle(self, elements: list[ET.Element]) -> None:
        """Set the transforms and single Dr.Jit values (a field of view, a colour) of ``elements`` (all that a later
        frame may set: which ones will change, another file of the animation tells only then) to themselves, opaque.
        Loaded, a camera derives its inner transforms from the file's double-precision ``to_world``; set, from the
        scene's single-precision one: a few ulps apart, which a sequence's history carried into other images from
        the third frame on (docs/experiments.md, sixty-eighth session). Settled, a loaded frame is a set frame to
        the bit, and its values are opaque from the first frame on, so the kernels recorded for it replay."""
        import drjit as dr

        prefixes = tuple(f"{name}." for element in elements for name in _ids(element))
        parameters = mi.traverse(self.scene)
        self._apply({key: parameters[key] for key in parameters.keys() if key.startswith(prefixes)
                     and (is_transform(parameters[key]) and not _scalar(parameters[key])
                          or dr.is_jit_v(parameters[key]) and dr.width(parameters[key]) == 1)})

    def _set(self, file: _File, values: dict[str, str], parameters: dict[str, str]) -> None:
        """Set on the held scene the elements of ``file`` with ``values`` that differ from the held ones: those that
        read a changed parameter (the held file), or whose XML differs (another file); :class:`_Whole` (nothing set)
        where one of their changes is not one ``mi.traverse`` can set."""
        if [(e.tag, e.get("id")) for e, _ in self.file.texts] != [(e.tag, e.get("id")) for e, _ in file.texts]:
            raise _Whole(f"{file.path.name} is made of other elements than {self.path.name}")
        changed = {name for name in values.keys() | self.values.keys() if values.get(name) != self.values.get(name)}
        pairs = [(old, new) for (old, old_text), (new, new_text) in zip(self.file.texts, file.texts)
                 if old_text != new_text or any(f"${name}" in new_text for name in changed)]
        if not pairs:
            return
        resolved = [(_resolved(old, self.values), _resolved(new, values)) for old, new in pairs]
        names = [_changes(old, new) for old, new in resolved]
        elements = [new for _, new in pairs]
        moved = [new for (_, new), (old_resolved, new_resolved), element_names in zip(pairs, resolved, names)
                 if not element_names and _moved_only(old_resolved, new_resolved)]
        loaded = self._loaded(file, elements, moved, parameters)
        held = mi.traverse(self.scene)  # read here; set through another (reading marks a value for the update)
        new_values = {}
        for element, element_names in zip(elements, names):
            new_values.update(_element_values(element, element_names, loaded, held))
        self._apply(new_values)

    def _loaded(self, file: _File, elements: list[ET.Element], moved: list[ET.Element],
                parameters: dict[str, str]) -> dict:
        """The ``mi.traverse`` values of ``elements`` of ``file``, by key. Each of those that only ``moved`` gets its
        ``to_world`` from a rectangle's (:func:`_proxy`) where loading it (an environment map's image, a shape group's
        meshes) costs more: checked against its own load the first time it moves (:attr:`proxies`), a sphere with a
        centre failing it."""
        trusted = [element for element in moved if self.proxies.get(element.get("id"))]
        tried = [element for element in moved if self.proxies.get(element.get("id")) is not False]
        rest = [element for element in elements if not any(element is other for other in trusted)]
        loaded = self._load_part(file, rest, parameters) if rest else {}
        by_proxy = self._load_part(file, [_proxy(element) for element in tried], parameters) if tried else {}
        for element in tried:
            key = f"{element.get('id')}.to_world"
            if element.get("id") not in self.proxies:
                self.proxies[element.get("id")] = key in loaded and key in by_proxy and \
                    np.array_equal(value_array(loaded[key]), value_array(by_proxy[key]))
        return {**{f"{element.get('id')}.to_world": by_proxy[f"{element.get('id')}.to_world"]
                   for element in trusted}, **loaded}

    def _load_part(self, file: _File, elements: list[ET.Element], parameters: dict[str, str]) -> dict:
        """The ``mi.traverse`` values of ``elements`` of ``file``, loaded alone (with what they refer to), by key."""
        part = _part(file.root, elements)
        text = _attribute_text(part)
        loaded = mi.traverse(load_tree(part, file.path, {name: value for name, value in parameters.items()
                                                          if f"${name}" in text}, whole=False))
        return {key: loaded[key] for key in loaded.keys()}

    def _apply(self, values: dict) -> None:
        """Set ``values`` (``mi.traverse`` keys) on the held scene, opaque, in one update; a value equal to the held
        one (a translated mesh's normals) is set all the same."""
        if not values:
            return
        setting = mi.traverse(self.scene)
        setting.keep([re.escape(key) + "$" for key in values])
        for key, value in values.items():
            setting[key] = opaque_value(value)
            setting.set_dirty(key)
        setting.update()


def _moved_only(old: ET.Element, new: ET.Element) -> bool:
    """Whether the resolved elements ``old`` and ``new`` (:func:`_resolved`) differ in their ``to_world`` alone, and are
    not a mesh (whose vertices the transform moves)."""
    def rest(element: ET.Element) -> tuple:
        kept = [child for child in element if not (child.tag == "transform" and child.get("name") == "to_world")]
        return element.tag, element.attrib, element.text, [ET.tostring(child) for child in kept]

    return new.get("type") not in MESH_TYPES and rest(old) == rest(new)


def _proxy(element: ET.Element) -> ET.Element:
    """A rectangle with ``element``'s id and ``to_world``: it loads in a millisecond, and its ``to_world`` is the
    element's where the element keeps the file's transform as it is (checked: :meth:`SceneFrames._loaded`)."""
    proxy = ET.Element("shape", {"type": "rectangle", "id": element.get("id")})
    proxy.extend(copy.deepcopy(transform) for transform in element.findall("transform[@name='to_world']"))
    return proxy


def _element_values(element: ET.Element, names: list[str], loaded, held) -> dict:
    """The parameters of ``element`` (its ids' keys) in ``loaded`` (its part, loaded alone) that differ from the held
    scene's (``held``), with a moved mesh's normals; :class:`_Whole` where they are not the held ones' kind and size,
    or a changed property among ``names`` shows in none of them."""
    prefixes = tuple(f"{name}." for name in _ids(element))
    mine = {key: loaded[key] for key in loaded.keys() if key.startswith(prefixes)}
    if any(key not in held for key in mine):
        raise _Whole(f"its <{element.tag}> gains a parameter")
    old = {key: value_array(held[key]) for key in mine}
    if any(type(held[key]) is not type(value) or old[key].shape != value_array(value).shape
           for key, value in mine.items()):
        raise _Whole(f"a parameter of its <{element.tag}> changes kind or size")
    differ = {key: value for key, value in mine.items() if not np.array_equal(value_array(value), old[key])}
    hidden = [name for name in names if not any(_names(key, name) for key in differ)]
    if hidden:  # a change mi.traverse does not show would be lost
        raise _Whole(f"no parameter of its <{element.tag}> shows the change of '{hidden[0]}'")
    # a mesh given new vertices without its normals gets normals Mitsuba sums anew (float atomics: other bits each
    # run), smooth where its file's were not
    normals = {key.replace("vertex_positions", "vertex_normals") for key in differ if key.endswith("vertex_positions")}
    return {**differ, **{key: mine[key] for key in normals if key in mine}}


class _Whole(Exception):
    """A frame's change that cannot be set on the held scene: the frame is loaded whole; the message says why."""


def name_elements(root: ET.Element) -> None:
    """Give each top-level element of :data:`SETTABLE_ELEMENTS` without an id one (:data:`ID_PREFIX` and its place)."""
    for index, element in enumerate(root):
        if element.tag in SETTABLE_ELEMENTS and not element.get("id"):
            element.set("id", f"{ID_PREFIX}{index}")


def value_array(value) -> np.ndarray:
    """A ``mi.traverse`` value as an array to compare: a transform's matrix, else its values."""
    return np.array(value.matrix if is_transform(value) else value)


def is_transform(value) -> bool:
    """Whether a ``mi.traverse`` value is a transform (other Dr.Jit arrays, a colour too, have a ``matrix``)."""
    return "Transform" in type(value).__name__


def opaque_value(value):
    """A ``mi.traverse`` value made again from its numbers (a transform through its scalar type), opaque: a copy
    of another loaded scene's value had the frozen kernels record again at every frame (a camera that turned: 80-150
    ms a 256x256 frame; docs/experiments.md, sixty-seventh session). A buffer (a mesh's vertices) is copied: a moved
    mesh has the kernels run plain anyway."""
    import drjit as dr

    if _scalar(value):  # a scalar value (a texture's to_uv) is a literal anyway
        return type(value)(value)
    if is_transform(value):
        matrix = np.array(value.matrix, np.float64)
        value = type(value)(getattr(mi, "Scalar" + type(value).__name__)(matrix.reshape(matrix.shape[:2])))
    elif dr.width(value) == 1:
        value = type(value)(*np.array(value).ravel().tolist())
    else:
        value = type(value)(value)
    dr.make_opaque(value)
    return value


def _scalar(value) -> bool:
    """Whether a ``mi.traverse`` value is of a scalar type (``ScalarAffineTransform3f``...), not a Dr.Jit one."""
    return type(value).__name__.startswith("Scalar")


def _attribute_text(element: ET.Element) -> str:
    """The attribute values of ``element`` and the elements in it, one per line: Mitsuba replaces ``$name`` in
    them wherever it occurs, so an element reads the parameter ``name`` where ``$name`` is in this text."""
    return "\n".join(text for node in element.iter() for text in node.attrib.values())


def _resolved(element: ET.Element, values: dict[str, str]) -> ET.Element:
    """A copy of ``element`` with the ``$name`` of its attributes replaced by ``values`` (longest names first), to
    compare two frames' elements."""
    names = sorted(values, key=len, reverse=True)
    resolved = copy.deepcopy(element)
    for node in resolved.iter():
        for attribute, text in node.attrib.items():
            for name in names:
                text = text.replace(f"${name}", values[name])
            node.set(attribute, text)
    return resolved


def _changes(element: ET.Element, new_element: ET.Element) -> list[str]:
    """The XML property names whose values change from ``element`` to ``new_element``, both resolved
    (:func:`_resolved`) (a transform's or a mesh file's change shows in its parameters wherever it changes anything: a
    translation by 0 written anew, a file of the same mesh, are no change); :class:`_Whole` where a change is not one
    a frame may set."""
    if element.tag not in SETTABLE_ELEMENTS:
        raise _Whole(f"its <{element.tag}> reads a parameter that changed")
    names: list[str] = []

    def walk(old: ET.Element, new: ET.Element, parents: tuple[ET.Element, ...]) -> None:
        if old.tag != new.tag or old.keys() != new.keys() or len(old) != len(new):
            raise _Whole(f"its <{element.tag}> changes structure")
        for attribute in old.keys():
            if old.get(attribute) == new.get(attribute):
                continue
            if any(parent.tag == "transform" for parent in parents):
                continue
            if old.tag in VALUE_TAGS and attribute == "value":
                names.append(old.get("name", ""))
                continue
            mesh = parents and parents[-1].tag == "shape" and parents[-1].get("type") in MESH_TYPES
            if not (old.tag == "string" and old.get("name") == "filename" and attribute == "value" and mesh):
                label = f"<{old.tag} name=\"{old.get('name')}\">" if old.get("name") else f"<{old.tag}>"
                raise _Whole(f"{label} of its <{element.tag}> changes")
        for a, b in zip(old, new):
            walk(a, b, (*parents, old))

    walk(element, new_element, ())
    return names


def _names(key: str, name: str) -> bool:
    """Whether the ``mi.traverse`` parameter ``key`` is the XML property ``name``'s."""
    name = TRAVERSE_NAMES.get(name, name)
    return key.endswith(f".{name}") or key.endswith(f".{name}.value")


def _ids(element: ET.Element) -> list[str]:
    """The ids ``element`` defines (its own and its children's; a ``<ref>`` defines none)."""
    return [node.get("id") for node in element.iter() if node.get("id") and node.tag != "ref"]


def _part(root: ET.Element, elements: list[ET.Element]) -> ET.Element:
    """A ``<scene>`` of ``elements``, the top-level elements they refer to (``<ref id>``, in turn) and the defaults,
    in the file's order; elements not of the file (:func:`_proxy`) last."""
    by_id = {element.get("id"): element for element in root if element.get("id")}
    wanted, queue = {id(element) for element in elements}, list(elements)
    while queue:
        for ref in queue.pop().iter("ref"):
            target = by_id.get(ref.get("id"))
            if target is not None and id(target) not in wanted:
                wanted.add(id(target))
                queue.append(target)
    part = ET.Element("scene", root.attrib)
    part.extend(element for element in root if element.tag == "default" or id(element) in wanted)
    part.extend(element for element in elements if not any(element is mine for mine in root))
    return part
