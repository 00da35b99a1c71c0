"""Procedural Mitsuba scenes for training and evaluating the GAN pre-completion.

:func:`scene_description` turns a seed into a ``mi.load_dict`` description;
each seed is a different scene (the generator draws everything from
``numpy.random.default_rng([seed, SCENE_STREAM])``). Two layouts, 65 % rooms:

- ``room``: floor, back and side walls, often a ceiling and a front wall behind
  the camera, sometimes a window with a sun (directional light) and sky
  outside, lit by ceiling area lights, point, spot or sphere lights;
- ``open``: a large floor with a few backdrop panels under an environment map
  (a numpy-made sky with an optional sun disc) or a constant sky, with a sun
  and sometimes point or spot lights.

Objects (2-8): boxes, spheres, capped cylinders, thin poles, tables (thin
legs), and meshes built in code (torus, cone, pyramid, prism, vase, blob), some
stacked. Materials: diffuse (plain or textured: checkerboard, stripes, noise,
wood, tiles), plastic, rough plastic, smooth and rough metal, glass and rough
glass. Cameras: perspective, field of view 35-75 degrees, varied positions.

``exposure`` multiplies every emitter; radiance is linear in it, so the
dataset builder picks it from a cheap preview to put the image in a display
range.
"""
from __future__ import annotations

import math

import numpy as np

from . import meshes, textures

SCENE_STREAM = 0x5CE7E
MAX_DEPTH = 8


def _T():
    import mitsuba as mi
    return mi.ScalarTransform4f()


def _rgb(value) -> dict:
    return {"type": "rgb", "value": [float(v) for v in np.broadcast_to(value, 3)]}


def _unit(vector) -> list[float]:
    vector = np.asarray(vector, np.float64)
    return (vector / np.linalg.norm(vector)).tolist()


# ----------------------------------------------------------------------------- materials

def _texture(rng: np.random.Generator, repeat: float) -> dict:
    import mitsuba as mi
    _, image = textures.random_texture(rng)
    return {"type": "bitmap", "bitmap": textures.to_bitmap(image), "filter_type": "bilinear",
            "to_uv": mi.ScalarTransform3f().scale([repeat, repeat])}


def _reflectance(rng: np.random.Generator, textured: bool, repeat: float) -> dict:
    return _texture(rng, repeat) if textured else _rgb(textures.random_color(rng))


MATERIALS = ("diffuse", "textured", "plastic", "roughplastic", "conductor", "roughconductor",
             "dielectric", "roughdielectric")
MATERIAL_WEIGHTS = (0.28, 0.16, 0.08, 0.14, 0.08, 0.12, 0.09, 0.05)


def random_material(rng: np.random.Generator, has_uv: bool = True, repeat: float = 1.0,
                    kinds: tuple[str, ...] = MATERIALS, weights: tuple[float, ...] | None = None) -> dict:
    """A random BSDF description; textures only on shapes with UVs."""
    weights = np.asarray(weights or [MATERIAL_WEIGHTS[MATERIALS.index(k)] for k in kinds], np.float64)
    kind = str(rng.choice(kinds, p=weights / weights.sum()))
    textured = has_uv and rng.random() < 0.5
    if kind == "textured":
        kind, textured = "diffuse", has_uv
    if kind == "diffuse":
        return {"type": "diffuse", "reflectance": _reflectance(rng, textured, repeat)}
    if kind == "plastic":
        return {"type": "plastic", "diffuse_reflectance": _reflectance(rng, textured, repeat),
                "int_ior": float(rng.uniform(1.4, 1.6))}
    if kind == "roughplastic":
        return {"type": "roughplastic", "distribution": "ggx", "alpha": float(rng.uniform(0.05, 0.4)),
                "diffuse_reflectance": _reflectance(rng, textured, repeat)}
    metal = str(rng.choice(["Au", "Cu", "Al", "Ag"]))
    if kind == "conductor":
        return {"type": "conductor", "material": metal}
    if kind == "roughconductor":
        return {"type": "roughconductor", "material": metal, "distribution": "ggx",
                "alpha": float(rng.uniform(0.05, 0.5))}
    if kind == "dielectric":
        return {"type": "dielectric", "int_ior": float(rng.uniform(1.33, 1.7))}
    return {"type": "roughdielectric", "distribution": "ggx", "alpha": float(rng.uniform(0.05, 0.3)),
            "int_ior": float(rng.uniform(1.33, 1.7))}


def _surface_material(rng: np.random.Generator, repeat: float) -> dict:
    """Floors and walls: mostly diffuse, often textured, sometimes glossy."""
    return random_material(rng, True, repeat, ("diffuse", "textured", "roughplastic", "roughconductor"),
                           (0.45, 0.35, 0.17, 0.03))


# ----------------------------------------------------------------------------- shapes

def _panel(base, u0: float, u1: float, v0: float, v1: float):
    """Rectangle covering [u0, u1] x [v0, v1] of a wall whose local plane is ``base``."""
    return base.translate([(u0 + u1) / 2, (v0 + v1) / 2, 0]).scale([(u1 - u0) / 2, (v1 - v0) / 2, 1])


def _wall(name: str, base, width: float, height: float, bsdf: dict, hole=None) -> dict:
    """A wall [-width/2, width/2] x [0, height] in ``base``'s plane, facing its +z, with an optional hole."""
    half = width / 2
    if hole is None:
        pieces = [(-half, half, 0, height)]
    else:
        hu0, hu1, hv0, hv1 = hole
        pieces = [(-half, half, 0, hv0), (-half, half, hv1, height), (-half, hu0, hv0, hv1), (hu1, half, hv0, hv1)]
    return {f"{name}_{i}": {"type": "rectangle", "to_world": _panel(base, *p), "bsdf": bsdf}
            for i, p in enumerate(pieces) if p[1] - p[0] > 1e-3 and p[3] - p[2] > 1e-3}


def _box(center, size, angle: float, bsdf: dict) -> dict:
    return {"type": "cube", "bsdf": bsdf,
            "to_world": _T().translate(list(center)).rotate([0, 1, 0], angle).scale([s / 2 for s in size])}


def _cylinder(base, height: float, radius: float, bsdf: dict, prefix: str) -> dict:
    top = [base[0], base[1] + height, base[2]]
    return {f"{prefix}": {"type": "cylinder", "p0": list(base), "p1": top, "radius": radius, "bsdf": bsdf},
            f"{prefix}_cap": {"type": "disk", "bsdf": bsdf,
                              "to_world": _T().translate(top).rotate([1, 0, 0], -90).scale(radius)}}


def _mesh(rng: np.random.Generator, name: str, center, size: float, bsdf: dict):
    kind = str(rng.choice(["torus", "cone", "pyramid", "prism", "vase", "blob"]))
    vertices, faces = {"torus": lambda: meshes.torus(0.35, rng.uniform(0.08, 0.18)),
                       "cone": meshes.cone, "pyramid": meshes.pyramid,
                       "prism": lambda: meshes.prism(int(rng.integers(3, 9))),
                       "vase": lambda: meshes.vase(rng), "blob": lambda: meshes.blob(rng)}[kind]()
    lowest = float(vertices[:, 1].min())
    transform = _T().translate([center[0], center[1] - lowest * size, center[2]]) \
        .rotate([0, 1, 0], float(rng.uniform(0, 360))).scale(size)
    return meshes.to_mitsuba(name, vertices, faces, bsdf, transform)


def _objects(rng: np.random.Generator, area: tuple[float, float, float, float]) -> dict:
    """2-8 objects standing on the floor (y = 0) inside ``area`` = (x0, x1, z0, z1)."""
    x0, x1, z0, z1 = area
    placed: list[tuple[float, float, float]] = []
    shapes: dict = {}
    count = int(rng.integers(2, 9))
    for index in range(count * 4):
        if len(placed) == count:
            break
        size = float(rng.uniform(0.25, 1.1))
        x, z = rng.uniform(x0 + size / 2, x1 - size / 2), rng.uniform(z0 + size / 2, z1 - size / 2)
        if any(math.hypot(x - px, z - pz) < (size + ps) / 2 * 0.9 for px, pz, ps in placed):
            continue
        placed.append((x, z, size))
        name = f"obj{index}"
        kind = str(rng.choice(["box", "sphere", "cylinder", "pole", "table", "mesh"],
                              p=[0.24, 0.2, 0.14, 0.07, 0.07, 0.28]))
        bsdf = random_material(rng, has_uv=kind in ("box", "sphere", "cylinder"), repeat=float(rng.uniform(1, 3)))
        top = size
        if kind == "box":
            dims = [size * rng.uniform(0.5, 1.0), size * rng.uniform(0.3, 1.4), size * rng.uniform(0.5, 1.0)]
            shapes[name] = _box([x, dims[1] / 2, z], dims, float(rng.uniform(0, 90)), bsdf)
            top = dims[1]
        elif kind == "sphere":
            radius = size / 2
            lift = radius if rng.random() < 0.8 else radius + float(rng.uniform(0.2, 1.0))
            shapes[name] = {"type": "sphere", "center": [x, lift, z], "radius": radius, "bsdf": bsdf}
            top = 0.0
        elif kind == "cylinder":
            shapes.update(_cylinder([x, 0, z], size * rng.uniform(0.6, 1.6), size / 2 * rng.uniform(0.4, 1), bsdf, name))
            top = 0.0
        elif kind == "pole":
            shapes.update(_cylinder([x, 0, z], float(rng.uniform(1.0, 2.5)), float(rng.uniform(0.015, 0.05)), bsdf, name))
            top = 0.0
        elif kind == "table":
            height, thick = float(rng.uniform(0.5, 0.9)), 0.04
            leg = random_material(rng, has_uv=False)
            shapes[name] = _box([x, height - thick / 2, z], [size, thick, size * 0.8], 0.0, bsdf)
            for k, (sx, sz) in enumerate([(-1, -1), (-1, 1), (1, -1), (1, 1)]):
                shapes.update(_cylinder([x + sx * size * 0.42, 0, z + sz * size * 0.34], height - thick,
                                        0.025, leg, f"{name}_leg{k}"))
            top = height
        else:
            shapes[name] = _mesh(rng, name, [x, 0.0, z], size, bsdf)
            top = 0.0
        if top > 0 and rng.random() < 0.35:  # stack a small object on top
            small = size * float(rng.uniform(0.2, 0.4))
            shapes[name + "_top"] = {"type": "sphere", "center": [x, top + small, z], "radius": small,
                                     "bsdf": random_material(rng)}
    return shapes


# ----------------------------------------------------------------------------- lights

def _area_rect(center, size: float, facing, radiance, name: str) -> dict:
    """A one-sided rectangular area light at ``center`` emitting towards ``facing``."""
    target = (np.asarray(center) + np.asarray(facing)).tolist()
    up = [0, 0, 1] if abs(facing[1]) > 0.9 else [0, 1, 0]
    return {name: {"type": "rectangle", "to_world": _T().look_at(origin=list(center), target=target, up=up)
                   .scale([size / 2, size / 2, 1]),
                   "emitter": {"type": "area", "radiance": _rgb(radiance)},
                   "bsdf": {"type": "diffuse", "reflectance": _rgb(0.0)}}}


def _warm_white(rng: np.random.Generator) -> np.ndarray:
    tint = np.array([1.0, rng.uniform(0.8, 1.0), rng.uniform(0.6, 1.0)])
    return tint if rng.random() < 0.7 else tint[::-1]


def _sky(rng: np.random.Generator, scale: float) -> dict:
    if rng.random() < 0.6:
        return {"sky": {"type": "envmap", "bitmap": textures.to_bitmap(textures.sky_envmap(rng)),
                        "scale": float(scale * rng.uniform(0.3, 1.2))}}
    return {"sky": {"type": "constant", "radiance": _rgb(textures.random_color(rng, 0.3, 1.0) * scale
                                                         * rng.uniform(0.2, 1.0))}}


def _sun(rng: np.random.Generator, direction, scale: float) -> dict:
    return {"sun": {"type": "directional", "direction": _unit(direction),
                    "irradiance": _rgb(_warm_white(rng) * scale * rng.uniform(2, 8))}}


def _local_lights(rng: np.random.Generator, bounds, ceiling: float | None, scale: float,
                  target, force: bool) -> dict:
    """Point, spot, sphere and ceiling area lights inside ``bounds`` = (x0, x1, z0, z1)."""
    x0, x1, z0, z1 = bounds
    top = ceiling if ceiling is not None else float(rng.uniform(2.5, 4.5))
    lights: dict = {}

    def position(low: float):
        return [float(rng.uniform(x0 + 0.3, x1 - 0.3)), float(rng.uniform(min(low, top - 0.2), top - 0.2)),
                float(rng.uniform(z0 + 0.3, z1 - 0.3))]

    if ceiling is not None and (rng.random() < 0.6 or force):
        for i in range(int(rng.integers(1, 3))):
            center = position(top - 0.05)
            center[1] = top - 0.01
            size = float(rng.uniform(0.3, 1.2))
            lights.update(_area_rect(center, size, [0, -1, 0], _warm_white(rng) * scale * rng.uniform(4, 16) / size,
                                     f"ceiling_light{i}"))
    if rng.random() < 0.35:
        lights["point"] = {"type": "point", "position": position(1.0),
                           "intensity": _rgb(_warm_white(rng) * scale * rng.uniform(3, 20))}
    if rng.random() < 0.35:
        lights["spot"] = {"type": "spot", "cutoff_angle": float(rng.uniform(20, 50)),
                          "beam_width": float(rng.uniform(10, 20)),
                          "to_world": _T().look_at(origin=position(1.5), target=list(target), up=[0, 1, 0]),
                          "intensity": _rgb(_warm_white(rng) * scale * rng.uniform(10, 60))}
    if rng.random() < 0.15 or (force and not lights):
        radius = float(rng.uniform(0.05, 0.2))
        lights["sphere_light"] = {"type": "sphere", "center": position(1.0), "radius": radius,
                                  "emitter": {"type": "area", "radiance": _rgb(_warm_white(rng) * scale
                                                                               * rng.uniform(1, 6) / radius ** 2)}}
    return lights


# ----------------------------------------------------------------------------- layouts

def _camera(rng: np.random.Generator, origin, target, resolution: int, spp: int) -> dict:
    import mitsuba as mi
    return {"type": "perspective", "fov": float(rng.uniform(35, 75)), "fov_axis": "x",
            "near_clip": 0.01, "far_clip": 200.0,
            "to_world": mi.ScalarTransform4f().look_at(origin=list(origin), target=list(target), up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": resolution, "height": resolution, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": spp}}


def _window_hole(rng: np.random.Generator, depth: float, height: float, widest: float,
                 sill: tuple[float, float], tall: tuple[float, float]) -> tuple[float, float, float, float]:
    """(u0, u1, v0, v1) of a window in the left wall: up to ``widest`` wide, sill and height drawn from ranges."""
    hu = rng.uniform(0.6, min(widest, depth - 1.5)) / 2
    hc = rng.uniform(-depth / 2 + hu + 0.5, depth / 2 - hu - 0.5)
    hv0 = rng.uniform(*sill)
    return hc - hu, hc + hu, hv0, min(height - 0.3, hv0 + rng.uniform(*tall))


def _walls(width: float, depth: float, height: float, bsdf: dict, hole=None) -> dict:
    """Back, left (with the window ``hole``, if any) and right walls of a room centred on the origin."""
    hw, hd = width / 2, depth / 2
    return {**_wall("back", _T().translate([0, 0, -hd]), width, height, bsdf),
            **_wall("left", _T().translate([-hw, 0, 0]).rotate([0, 1, 0], 90), depth, height, bsdf, hole),
            **_wall("right", _T().translate([hw, 0, 0]).rotate([0, 1, 0], -90), depth, height, bsdf)}


def _room(rng: np.random.Generator, exposure: float) -> tuple[dict, list, list]:
    width, depth, height = rng.uniform(4, 8), rng.uniform(4, 8), rng.uniform(2.5, 4)
    hw, hd = width / 2, depth / 2
    shapes: dict = {"floor": {"type": "rectangle", "bsdf": _surface_material(rng, float(rng.uniform(2, 6))),
                              "to_world": _T().rotate([1, 0, 0], -90).scale([hw, hd, 1])}}
    wall = _surface_material(rng, float(rng.uniform(1, 4)))
    window = rng.random() < 0.4
    hole = _window_hole(rng, depth, height, 2.5, (0.5, 1.2), (0.8, 2.0)) if window else None
    shapes.update(_walls(width, depth, height, wall, hole))
    has_ceiling = rng.random() < 0.8
    if has_ceiling:
        shapes["ceiling"] = {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": _rgb(rng.uniform(0.5, 0.9))},
                             "to_world": _T().translate([0, height, 0]).rotate([1, 0, 0], 90).scale([hw, hd, 1])}
    if rng.random() < 0.5:
        shapes.update(_wall("front", _T().translate([0, 0, hd]).rotate([0, 1, 0], 180), width, height, wall))
    if window and rng.random() < 0.6:  # window bars: thin geometry casting thin shadows
        hc, bars = (hole[0] + hole[1]) / 2, {"type": "diffuse", "reflectance": _rgb(rng.uniform(0.1, 0.8))}
        # the left wall's u axis runs along -z
        shapes["bar_v"] = _box([-hw, (hole[2] + hole[3]) / 2, -hc], [0.05, hole[3] - hole[2], 0.04], 0, bars)
        shapes["bar_h"] = _box([-hw, (hole[2] + hole[3]) / 2, -hc], [0.05, 0.04, hole[1] - hole[0]], 0, bars)
    area = (-hw + 0.3, hw - 0.3, -hd + 0.3, hd - 1.8)
    shapes.update(_objects(rng, area))
    target = [rng.uniform(-0.5, 0.5) * hw, rng.uniform(0.2, 1.0), rng.uniform(-hd + 0.5, 0)]
    lights: dict = {}
    if window:
        lights.update(_sun(rng, [rng.uniform(0.8, 1.2), -rng.uniform(0.3, 1.2), rng.uniform(-0.6, 0.6)], exposure))
        if rng.random() < 0.7:
            lights.update(_sky(rng, exposure))
    lights.update(_local_lights(rng, (-hw, hw, -hd, hd), height if has_ceiling else None, exposure, target,
                                force=not window))
    origin = [rng.uniform(-0.4, 0.4) * hw, rng.uniform(0.6, height - 0.4), rng.uniform(hd - 1.2, hd - 0.2)]
    return {**shapes, **lights}, origin, target


def _open(rng: np.random.Generator, exposure: float) -> tuple[dict, list, list]:
    shapes: dict = {"floor": {"type": "rectangle", "bsdf": _surface_material(rng, float(rng.uniform(4, 16))),
                              "to_world": _T().rotate([1, 0, 0], -90).scale([15, 15, 1])}}
    for i in range(int(rng.integers(0, 3))):  # backdrop panels
        angle = float(rng.uniform(-60, 60))
        base = _T().rotate([0, 1, 0], angle).translate([0, 0, -rng.uniform(2.5, 5)])
        shapes.update(_wall(f"panel{i}", base, float(rng.uniform(2, 6)), float(rng.uniform(1, 3)),
                            _surface_material(rng, float(rng.uniform(1, 3)))))
    shapes.update(_objects(rng, (-2.5, 2.5, -2.5, 2.0)))
    target = [rng.uniform(-0.5, 0.5), rng.uniform(0.2, 0.8), rng.uniform(-1, 0.5)]
    lights = _sky(rng, exposure)
    if rng.random() < 0.75:
        lights.update(_sun(rng, [rng.uniform(-1, 1), -rng.uniform(0.3, 1.5), rng.uniform(-1, 1)], exposure))
    lights.update(_local_lights(rng, (-3, 3, -3, 3), None, exposure, target, force=False))
    distance, azimuth = rng.uniform(3.5, 8), rng.uniform(-0.6, 0.6)
    origin = [target[0] + distance * math.sin(azimuth), rng.uniform(0.5, 4.0), target[2] + distance * math.cos(azimuth)]
    return {**shapes, **lights}, origin, target


def _mixed(rng: np.random.Generator, exposure: float) -> tuple[dict, list, list]:
    return (_room if rng.random() < 0.65 else _open)(rng, exposure)


def scene_description(seed: int, resolution: int = 128, exposure: float = 1.0, spp: int = 16) -> dict:
    """The ``mi.load_dict`` description of procedural scene ``seed``.

    Parameters
    ----------
    seed : which scene; the same seed always gives the same scene.
    resolution : square film side in pixels.
    exposure : multiplier on every emitter (radiance is linear in it).
    spp : the sensor sampler's sample count.
    """
    rng = np.random.default_rng([int(seed), SCENE_STREAM])
    children, origin, target = _mixed(rng, float(exposure))
    return {"type": "scene", "integrator": {"type": "path", "max_depth": MAX_DEPTH},
            "sensor": _camera(rng, origin, target, resolution, spp), **children}


def build_scene(seed: int, resolution: int = 128, exposure: float = 1.0, spp: int = 16):
    """Load procedural scene ``seed`` as an ``mi.Scene``."""
    import mitsuba as mi
    # Mitsuba's shape merging (optimize=True) orders the merged scene's shapes, and so its
    # area emitters, differently from one load to the next within a process (measured,
    # Mitsuba 3.9.1): emitter sampling, hence every sample, would then depend on what the
    # process loaded before. Serial loading without merging keeps the order of the description.
    return mi.load_dict(scene_description(seed, resolution, exposure, spp), parallel=False, optimize=False)
