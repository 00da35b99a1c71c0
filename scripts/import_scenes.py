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
import collections
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
REPOSITORY = "https://github.com/hchoi405/dppm-scenes"
DEFAULT_NAMES = ("dining-room", "living-room", "sponza", "veach-lamp")
HELD_OUT = ("classroom", "staircase")
#: scenes imported only for the GAN's training data (``gmcpt dataset --real``): none is an evaluation scene
TRAINING_NAMES = ("bathroom", "bathroom2", "living-room-2", "spaceship")

BITTERLI = "https://benedikt-bitterli.me/resources/"
CC_BY = "CC BY 3.0, https://creativecommons.org/licenses/by/3.0/"
CC0 = "CC0 1.0 (public domain), https://creativecommons.org/publicdomain/zero/1.0/"
MITSUBA_SCENES = "https://www.mitsuba-renderer.org/download.html"


def _camera_kept(fov: str, native: str, square: str) -> str:
    return f"source camera kept (fov {fov}): the native {native} view is the author's; a 256x256 film {square}"


def _mitsuba_example(name: str) -> str:
    return (f"not stated: no licence file in the source; it appears to be the Mitsuba 0.6 example scene `{name}` "
            f"({MITSUBA_SCENES}), published for use with Mitsuba")


TRAINING_FRAMING = ("source camera and its rand_sceneN variants kept; the dataset builder (`gmcpt dataset --real`) "
                    "renders them square, jittered and cropped")

def _bitterli_training(title: str, author: str, blend: int, licence: str, what: str) -> dict:
    """A training-only scene from Bitterli's Rendering Resources, whose folder carries a LICENSE.txt."""
    return dict(title=title, author=f"{author} (Blender scene, http://www.blendswap.com/blends/view/{blend})",
                licence=licence, framing=TRAINING_FRAMING,
                provenance=f"Benedikt Bitterli's Rendering Resources ({BITTERLI}), Mitsuba version; licence from "
                           "the folder's LICENSE.txt (copied here).",
                use=f"Training only (GAN data, never evaluated): {what}")


#: what is known of each scene's origin, and how its camera frames a 256x256 and the native film
SCENES = {
    "dining-room": dict(
        title="The Breakfast Room", author="Wig42 (Blender scene, http://www.blendswap.com/blends/view/75431)",
        licence=CC_BY,
        provenance="Benedikt Bitterli's Rendering Resources (" + BITTERLI + "), Mitsuba version; the dppm-scenes "
                   "folder has no LICENSE.txt; Bitterli's release of this scene (same camera), as copied in gmcpt's "
                   "../shared/scenes/breakfast-room, carries one naming Wig42 and CC BY 3.0. It is the scene of "
                   "gmcpt's `breakfast-room`, here lit by its sun and sky instead of a constant emitter.",
        notes="sun and sky through open windows (no glass), reachable by path tracing; the floor and the lower "
              "third stay dark (a third of the pixels below 0.01 at 256x256)",
        framing=_camera_kept("60 on x", "1280x720", "keeps its width and adds floor and ceiling (table, chairs, "
                             "lamps, painting, window in view)")),
    "living-room": dict(
        title="The Grey & White Room", author="Wig42 (Blender scene, http://www.blendswap.com/blends/view/75795)",
        licence=CC_BY,
        provenance="Benedikt Bitterli's Rendering Resources (" + BITTERLI + "), Mitsuba version; licence from the "
                   "folder's LICENSE.txt (copied here).",
        notes="environment map through open windows; bright and well lit, strong fireflies at low spp",
        framing=_camera_kept("90 on x", "1280x720", "keeps its width and adds floor and ceiling (windows, table, "
                             "sofa in view)")),
    "sponza": dict(
        title="Sponza Atrium", author="Marko Dabrovic (original 2002 model); Mitsuba conversion from COLLADA",
        licence="not stated: no licence file in the source; the model has long been redistributed freely for "
                "rendering research - credit Marko Dabrovic, and check its terms before publishing images",
        provenance="dppm-scenes folder `sponza`; the scene file says only 'Automatically converted from COLLADA' "
                   "(its `sponza.serialized` and textures appear to be the Mitsuba 0.6 example scene, "
                   + MITSUBA_SCENES + ").",
        notes="one small spherical light above the atrium; evenly lit, little black",
        framing=_camera_kept("96.7 on x", "1280x720", "keeps its width and adds floor and vault")),
    "veach-lamp": dict(
        title="Lamp and egg room (bidirectional test scene)",
        author="after the test scene of Eric Veach's thesis (1997); modeller of this version not stated",
        licence=_mitsuba_example("bidir") + " - credit Eric Veach",
        provenance="dppm-scenes folder `veach-lamp` (mesh file `bidir.serialized`); the scene file says only "
                   "'Automatically converted from COLLADA'.",
        notes="lamps aimed at the ceiling and a wall: almost all light is indirect, noisy at low spp; a hard case",
        framing=_camera_kept("57.3 on x", "1024x576", "keeps its width and adds floor and ceiling (both lamps, "
                             "table, egg in view)")),
    "box": dict(
        title="Box with glass and metal objects", author="not stated in the source",
        licence="unknown: no licence file and no attribution in the source; do not publish images of it "
                "without finding its origin",
        provenance="dppm-scenes folder `box`; the scene file says only 'Automatically converted from Wavefront OBJ'.",
        notes="mostly black: its two tiny lights are seen only through specular paths - a bad evaluation scene",
        framing=_camera_kept("35 on y", "800x600", "keeps its height and loses the sides")),
    "torus": dict(
        title="Torus in a glass cube", author="not stated in the source (a Rhino 5.0 model)",
        licence=_mitsuba_example("torus"),
        provenance="dppm-scenes folder `torus`; the scene file says 'Automatically converted from Rhino 5.0'.",
        notes="sun and sky on a floor, the torus inside a glass cube: mostly caustics and refraction",
        framing=_camera_kept("34.6 on x", "1024x768", "keeps its width and adds floor")),
    "bathroom": _bitterli_training("Contemporary Bathroom", "Mareck", 75302, CC0,
                                   "a small bathroom lit by one area light"),
    "bathroom2": dict(
        title="Bathroom (tiles, mirror, glass)", author="not stated in the source",
        licence="not stated: no licence file in the source; used only to render training data here, "
                "never published as images",
        provenance="dppm-scenes folder `bathroom2` (its meshes are Mitsuba `.serialized` files).",
        use="Training only (GAN data, never evaluated): tiled bathroom lit by a window area light; its "
            "environment texture is missing from the snapshot, so a uniform grey takes its place",
        framing=TRAINING_FRAMING),
    "living-room-2": _bitterli_training("The White Room", "Jay-Artist", 41683, CC_BY,
                                        "white living room lit through its windows"),
    "spaceship": _bitterli_training("4060.b Spaceship", "thecali", 75686, CC0,
                                    "a studio model under area lights, not an interior"),
}


class SceneImportError(Exception):
    """A one-line reason the import cannot go on."""


class Changes:
    """The README lines: one per distinct change, with how often it was made."""

    def __init__(self):
        self.counts = collections.Counter()

    def add(self, line: str) -> None:
        self.counts[line] += 1

    def lines(self) -> list[str]:
        return [line if count == 1 else f"{line} ({count} places)" for line, count in self.counts.items()]


# ---------------------------------------------------------------- helpers


def _param(element: ET.Element, name: str) -> ET.Element | None:
    return next((child for child in element if child.get("name") == name), None)


def _pop(element: ET.Element, name: str) -> ET.Element | None:
    child = _param(element, name)
    if child is not None:
        element.remove(child)
    return child


def _color(node: ET.Element | None) -> list[float] | None:
    """An rgb/spectrum constant as three floats; None for a texture or a spectrum with wavelengths."""
    if node is None or node.tag not in ("rgb", "spectrum") or ":" in node.get("value", ":"):
        return None
    values = [float(v) for v in re.split(r"[,\s]+", node.get("value").strip())]
    return values * 3 if len(values) == 1 else values


def _rgb(name: str, values) -> ET.Element:
    return ET.Element("rgb", name=name, value=" ".join(f"{v:.6g}" for v in values))


def snake_case(name: str) -> str:
    """Mitsuba 3's own rule for a 0.6 name: an underscore before each capital after a lower-case letter."""
    return re.sub(r"([a-z])([A-Z])", r"\1_\2", name).lower()


# ---------------------------------------------------------------- rules


def substitute_variables(root: ET.Element, changes: Changes) -> None:
    """Replace each ``$name`` by its ``<default>`` and drop the defaults: the imported scene stands alone."""
    defaults = {d.get("name"): d.get("value") for d in root.findall("default")}
    for node in root.iter():
        for key, value in node.attrib.items():
            for name in re.findall(r"\$(\w+)", value):
                if name in defaults:
                    node.set(key, value.replace(f"${name}", defaults[name]))
                    changes.add(f"substituted `${name}` by its default `{defaults[name]}`")
    for default in root.findall("default"):
        root.remove(default)
    if defaults:
        changes.add(f"removed the `<default>`s of {', '.join(f'`{n}`' for n in defaults)} (no `$` variables are left)")


def rename_parameters(root: ET.Element, changes: Changes) -> None:
    """camelCase to snake_case, as Mitsuba 3 does itself when it loads a 0.6 file; done here for a 3.0 file."""
    for node in root.iter():
        name = node.get("name")
        if name and snake_case(name) != name:
            node.set("name", snake_case(name))
            changes.add(f"renamed `{name}` to `{snake_case(name)}`")


def integrator_to_path(root: ET.Element, changes: Changes) -> None:
    """Photon mapping and the like become ``path`` with the scene's max depth (gmcpt wraps it itself)."""
    defaults = {d.get("name"): d.get("value") for d in root.findall("default")}
    for element in root.findall("integrator"):
        depth = next((c for c in element if c.get("name") in ("maxDepth", "max_depth")), None)
        if depth is not None and depth.get("value", "").startswith("$"):
            depth.set("value", defaults.get(depth.get("value")[1:], "-1"))
        kind = element.get("type", "")
        label = f"`{kind}`" + (f" (default `{defaults.get(kind[1:])}`)" if kind.startswith("$") else "")
        dropped = [child.get("name") for child in element if child is not depth]
        element.clear()
        element.set("type", "path")
        if depth is not None:
            depth.set("name", "max_depth")
            element.append(depth)
        note = f", dropped its {', '.join(f'`{d}`' for d in dropped)}" if dropped else ""
        depth_text = depth.get("value") if depth is not None else "unset"
        changes.add(f"integrator {label} replaced by `path` with the scene's `max_depth` {depth_text}{note}")


def _glossy(element: ET.Element, alpha: float, source: str, changes: Changes) -> None:
    """A diffuse + Phong/Ward lobe as Mitsuba 3 has it: a blend of ``diffuse`` and a rough mirror.

    The blend weight is the specular share of the albedo, so the reflected energy of each lobe is kept;
    a textured diffuse part is kept as it is, its albedo taken as 0.5 (0.6's default) for the weight.
    """
    kd_node = _param(element, "diffuse_reflectance")
    texture = kd_node if kd_node is not None and _color(kd_node) is None else None
    kd = _color(kd_node) if kd_node is not None and texture is None else [0.5] * 3
    ks = _color(_param(element, "specular_reflectance")) or [0.2] * 3  # 0.6's defaults
    weight = sum(ks) / max(sum(kd) + sum(ks), 1e-9)
    conductor = ET.Element("bsdf", type="roughconductor")
    conductor.extend([ET.Element("string", name="material", value="none"),
                      ET.Element("string", name="distribution", value="beckmann"),
                      ET.Element("float", name="alpha", value=f"{alpha:.4g}"),
                      _rgb("specular_reflectance", [min(1.0, k / max(weight, 1e-9)) for k in ks])])
    ident = element.get("id")
    element.clear()
    if ident:
        element.set("id", ident)
    if weight > 0.999:
        element.set("type", "roughconductor")
        element.extend(list(conductor))
        changes.add(f"bsdf `{source}` `{ident}` (no diffuse part) became `roughconductor` (its specular "
                    f"reflectance, Beckmann alpha {alpha:.3g})")
        return
    diffuse = ET.Element("bsdf", type="diffuse")
    if texture is not None:
        texture.set("name", "reflectance")
        diffuse.append(texture)
        changes.add(f"bsdf `{source}` `{ident}`: its textured diffuse part kept unscaled in the blend")
    else:
        diffuse.append(_rgb("reflectance", [min(1.0, k / (1 - weight)) for k in kd]))
    element.set("type", "blendbsdf")
    element.append(ET.Element("float", name="weight", value=f"{weight:.4g}"))
    element.extend([diffuse, conductor])
    changes.add(f"bsdf `{source}` `{ident}` became `blendbsdf` of `diffuse` and a mirror `roughconductor` "
                f"(Beckmann alpha {alpha:.3g}, weight {weight:.3g} = specular share of the albedo)")


def ward_bsdf(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 has no ``ward``: its alpha is a Beckmann-like roughness, kept as it is."""
    alpha = _param(element, "alpha")
    _glossy(element, float(alpha.get("value")) if alpha is not None else 0.1, "ward", changes)


def phong_bsdf(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 has no ``phong``: exponent n maps to Beckmann alpha sqrt(2 / (n + 2)) (Walter et al. 2007)."""
    exponent = _param(element, "exponent")
    n = float(exponent.get("value")) if exponent is not None else 30.0
    _glossy(element, (2 / (n + 2)) ** 0.5, "phong", changes)


def roughdiffuse_bsdf(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 has no Oren-Nayar ``roughdiffuse``: plain Lambertian with the same reflectance."""
    element.set("type", "diffuse")
    for name in ("alpha", "use_fast_approx"):
        if _pop(element, name) is not None:
            changes.add(f"bsdf `roughdiffuse` became `diffuse`: dropped `{name}` (Oren-Nayar roughness)")


def coatings(root: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 has no ``coating``: a coated diffuse becomes ``plastic``, any other coated BSDF loses its coat.

    Run before the plugin rules, so that the BSDF taking the coating's place gets its own rules.
    """
    for parent in list(root.iter()):
        for index, element in enumerate(list(parent)):
            nested = element.find("bsdf") if (element.tag, element.get("type")) == ("bsdf", "coating") else None
            if nested is None:
                continue
            ident, ior = element.get("id"), _param(element, "int_ior")
            if nested.get("type") == "diffuse":
                reflectance = _param(nested, "reflectance")
                reflectance = reflectance if reflectance is not None else _param(nested, "diffuse_reflectance")
                nested = ET.Element("bsdf", type="plastic")
                if reflectance is not None:
                    reflectance.set("name", "diffuse_reflectance")
                    nested.append(reflectance)
                if ior is not None:
                    nested.append(ior)
                changes.add(f"bsdf `coating` over `diffuse` (id `{ident}`) became `plastic` "
                            "(coat thickness and absorption dropped)")
            else:
                changes.add(f"bsdf `coating` over `{nested.get('type')}` (id `{ident}`) lost its coat: "
                            "Mitsuba 3 has no `coating`")
            if ident:
                nested.set("id", ident)
            parent.remove(element)
            parent.insert(index, nested)


def diffuse_alias(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 0.6 let ``diffuse`` take ``diffuseReflectance``; Mitsuba 3 knows only ``reflectance``."""
    node = _param(element, "diffuse_reflectance")
    if node is not None and _param(element, "reflectance") is None:
        node.set("name", "reflectance")
        changes.add("bsdf `diffuse`: `diffuse_reflectance` (a 0.6 alias) became `reflectance`")


def spectrum_triples(root: ET.Element, changes: Changes) -> None:
    """A 0.6 ``<spectrum>`` of three plain values is an RGB triple in 0.6's RGB mode; Mitsuba 3 wants ``<rgb>``."""
    for node in root.iter("spectrum"):
        values = [v for v in re.split(r"[,\s]+", node.get("value", "").strip()) if v]
        if len(values) == 3 and ":" not in node.get("value"):
            node.tag = "rgb"
            node.set("value", " ".join(values))
            changes.add("`<spectrum>` of three values became `<rgb>` (0.6 read it as RGB)")


def conductor_ext_eta(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 conductors sit in vacuum: an exterior index other than 1 divides ``eta`` and ``k``."""
    ext = _pop(element, "ext_eta")
    if ext is None:
        return
    try:
        value = float(ext.get("value"))
    except ValueError:
        value = 1.0  # a named medium ("air", 1.0003): indistinguishable from vacuum here
    if abs(value - 1) < 1e-3:
        changes.add(f"dropped `ext_eta` = {ext.get('value')} on {element.get('type')} (Mitsuba 3 assumes 1)")
        return
    for name in ("eta", "k"):
        values = _color(_param(element, name))
        if values is not None:
            _pop(element, name)
            element.append(_rgb(name, [v / value for v in values]))
    changes.add(f"folded `ext_eta` = {value} into `eta` and `k` of {element.get('type')} (Mitsuba 3 has no ext_eta)")


def rough_distribution(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 microfacets are ``beckmann`` or ``ggx``: 0.6's ``phong`` (its alpha is a Beckmann-equivalent
    roughness, converted to an exponent inside 0.6) becomes ``beckmann`` with the same alpha."""
    node = _param(element, "distribution")
    if node is not None and node.get("value") not in ("beckmann", "ggx"):
        changes.add(f"{element.get('type')} distribution `{node.get('value')}` became `beckmann` (same alpha)")
        node.set("value", "beckmann")


def smooth_alpha(element: ET.Element, changes: Changes) -> None:
    """A smooth ``conductor``/``dielectric`` has no roughness: Mitsuba 0.6 ignored ``alpha`` and ``distribution``
    there, 3 refuses them."""
    for name in ("alpha", "distribution"):
        if _pop(element, name) is not None:
            changes.add(f"dropped `{name}` on the smooth {element.get('type')} (ignored by Mitsuba 0.6 as well)")


def bitmap_filter(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 bitmaps filter ``bilinear`` or ``nearest``: mip-mapped filters become ``bilinear``."""
    node = _param(element, "filter_type")
    if node is not None and node.get("value") not in ("bilinear", "nearest"):
        changes.add(f"bitmap `filter_type` `{node.get('value')}` became `bilinear` (Mitsuba 3 has no mip-mapping)")
        node.set("value", "bilinear")


def bitmap_gamma(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 bitmaps have no ``gamma``: 1 (linear data) becomes ``raw``; any other value is dropped and the
    file read as Mitsuba 3 reads it (sRGB for 8-bit images, linear for EXR), the nearest it offers."""
    node = _pop(element, "gamma")
    if node is None:
        return
    if abs(float(node.get("value")) - 1) < 1e-6:
        element.append(ET.Element("boolean", name="raw", value="true"))
        changes.add("bitmap `gamma` 1 became `raw` true (linear values)")
    else:
        changes.add(f"bitmap `gamma` {node.get('value')} dropped (Mitsuba 3 has no gamma; its file's own encoding is used)")


def bitmap_texture(element: ET.Element, changes: Changes) -> None:
    bitmap_filter(element, changes)
    bitmap_gamma(element, changes)


def sunsky_emitter(element: ET.Element, changes: Changes) -> None:
    """Mitsuba 3's ``sunsky`` (Hosek-Wilkie) has +Z up where 0.6's had +Y, and takes an aperture, not a radius scale."""
    transform = _param(element, "to_world")
    if transform is None:
        transform = ET.SubElement(element, "transform", name="to_world")
    transform.insert(0, ET.Element("rotate", x="1", angle="-90"))  # applied first: local +Z onto 0.6's +Y
    changes.add("emitter `sunsky`: prepended a -90 degree rotation about x to `to_world` (Mitsuba 3's sky has "
                "+Z up, 0.6's +Y; `sun_direction` stays in world space)")
    scale = _pop(element, "sun_radius_scale")
    if scale is not None:
        aperture = 0.5338 * float(scale.get("value"))  # 0.5338 degrees: Mitsuba 3's default, the real sun
        element.append(ET.Element("float", name="sun_aperture", value=f"{aperture:.4g}"))
        changes.add(f"`sun_radius_scale` {scale.get('value')} became `sun_aperture` {aperture:.4g} degrees")
    changes.add("emitter `sunsky`: Mitsuba 3's model is Hosek-Wilkie, 0.6's Preetham: sky colour and "
                "brightness differ somewhat")


def ldrfilm_film(element: ET.Element, changes: Changes) -> None:
    """gmcpt renders linear radiance: a tonemapping ``ldrfilm`` becomes ``hdrfilm``."""
    element.set("type", "hdrfilm")
    changes.add("film `ldrfilm` became `hdrfilm` (its tonemapping parameters dropped)")
    for name in ("gamma", "exposure", "tonemap_method", "key", "burn", "pixel_format", "file_format"):
        _pop(element, name)


def ldsampler_sampler(element: ET.Element, changes: Changes) -> None:
    """gmcpt draws its own sample counts: a low-discrepancy sampler (power-of-two counts) becomes independent."""
    element.set("type", "independent")
    changes.add("sampler `ldsampler` became `independent`")


def hex_colours(root: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 reads no ``#rrggbb``: each becomes three floats (channel / 255) in the same tag, as 0.6
    read it, so an ``<srgb>`` is still linearised after this and an ``<rgb>`` stays linear."""
    for node in root.iter():
        value = node.get("value", "").strip() if node.tag in ("rgb", "srgb") else ""
        if re.fullmatch(r"#[0-9a-fA-F]{6}", value):
            node.set("value", " ".join(f"{int(value[i:i + 2], 16) / 255:.6g}" for i in (1, 3, 5)))
            changes.add(f"`<{node.tag}>` hexadecimal colour became three floats (channel / 255)")


def srgb_colour(root: ET.Element, changes: Changes) -> None:
    """Mitsuba 3 has no ``<srgb>``: gamma-encoded sRGB values are linearised into ``<rgb>``."""
    for node in root.iter("srgb"):
        values = [float(v) for v in re.split(r"[,\s]+", node.get("value").strip())]
        linear = [v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4 for v in values]
        node.tag = "rgb"
        node.set("value", " ".join(f"{v:.6g}" for v in linear))
        changes.add("`<srgb>` colour linearised into `<rgb>`")


#: rules that rewrite one plugin, by (element tag, plugin type)
PLUGIN_RULES = {
    ("bsdf", "ward"): ward_bsdf,
    ("bsdf", "phong"): phong_bsdf,
    ("bsdf", "roughdiffuse"): roughdiffuse_bsdf,
    ("bsdf", "diffuse"): diffuse_alias,
    ("bsdf", "conductor"): lambda e, c: (conductor_ext_eta(e, c), smooth_alpha(e, c)),
    ("bsdf", "roughconductor"): lambda e, c: (conductor_ext_eta(e, c), rough_distribution(e, c)),
    ("bsdf", "roughdielectric"): rough_distribution,
    ("bsdf", "roughplastic"): rough_distribution,
    ("bsdf", "dielectric"): smooth_alpha,
    ("texture", "bitmap"): bitmap_texture,
    ("emitter", "sunsky"): sunsky_emitter,
    ("film", "ldrfilm"): ldrfilm_film,
    ("sampler", "ldsampler"): ldsampler_sampler,
}

#: parameters Mitsuba 3 refuses and that change nothing it renders: (element tag, parameter, why)
DROPPED = (
    ("film", "banner", "Mitsuba 3 has no banner"),
    ("film", "attach_log", "Mitsuba 3 does not attach logs"),
    ("film", "high_quality_edges", "Mitsuba 3 has no such option"),
    ("film", "gamma", "an hdrfilm stores linear values"),
    ("shape", "max_smooth_angle", "Mitsuba 3 meshes keep the normals stored in the file"),
)


def apply_rules(root: ET.Element, changes: Changes) -> None:
    """Run each plugin rule on the elements it matches, then drop the parameters of ``DROPPED``."""
    for element in list(root.iter()):
        rule = PLUGIN_RULES.get((element.tag, element.get("type")))
        if rule is not None:
            rule(element, changes)
    for tag, name, why in DROPPED:
        for element in root.iter(tag):
            if _pop(element, name) is not None:
                changes.add(f"dropped {tag} parameter `{name}` ({why})")


def translate(root: ET.Element, changes: Changes) -> None:
    """All rules, in the order they depend on each other: integrator, variables, names, plugins."""
    if root.tag != "scene":
        raise SceneImportError(f"not a Mitsuba scene (root element <{root.tag}>)")
    version = root.get("version", "")
    integrator_to_path(root, changes)
    substitute_variables(root, changes)
    if not version.startswith(("2.", "3.")):
        rename_parameters(root, changes)
    hex_colours(root, changes)
    srgb_colour(root, changes)
    spectrum_triples(root, changes)
    coatings(root, changes)
    apply_rules(root, changes)
    root.set("version", "3.0.0")
    changes.add(f"scene `version` {version or 'unset'} -> 3.0.0")


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
