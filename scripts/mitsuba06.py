"""Mitsuba 0.6 -> 3 translation rules of ``import_scenes.py``: each rewrites the scene tree in place and says
what it changed, one README line per kind of change (:class:`Changes`)."""
from __future__ import annotations

import collections
import re
import xml.etree.ElementTree as ET


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
