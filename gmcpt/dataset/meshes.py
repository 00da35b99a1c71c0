"""Triangle meshes built in code (no files): torus, cone, pyramid, lumpy blob, prism.

Each builder returns ``(vertices (V, 3) float32, faces (F, 3) uint32)`` of a
closed, outward-facing mesh centred at the origin and about one unit across;
:func:`to_mitsuba` turns it into an ``mi.Mesh`` that ``mi.load_dict`` accepts
as a scene child.
"""
from __future__ import annotations

import numpy as np


def _grid_faces(rows: int, cols: int, wrap_rows: bool = False) -> np.ndarray:
    """Two triangles per cell of a rows x cols vertex grid (columns, and optionally rows, wrap around)."""
    faces = []
    for i in range(rows if wrap_rows else rows - 1):
        for j in range(cols):
            a, b = i * cols + j, i * cols + (j + 1) % cols
            c, d = ((i + 1) % rows) * cols + j, ((i + 1) % rows) * cols + (j + 1) % cols
            faces += [(a, c, b), (b, c, d)]
    return np.asarray(faces, np.uint32)


def torus(major: float = 0.35, minor: float = 0.15, segments: int = 32, rings: int = 16):
    """Torus around the y axis."""
    u = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    v = np.linspace(0, 2 * np.pi, rings, endpoint=False)
    uu, vv = np.meshgrid(u, v)  # (rings, segments)
    radius = major + minor * np.cos(vv)
    vertices = np.stack([radius * np.cos(uu), minor * np.sin(vv), radius * np.sin(uu)], -1).reshape(-1, 3)
    return vertices.astype(np.float32), _grid_faces(rings, segments, wrap_rows=True)


def _lathe(profile: np.ndarray, segments: int):
    """Surface of revolution of a (N, 2) (radius, height) profile from bottom to top, capped."""
    u = np.linspace(0, 2 * np.pi, segments, endpoint=False)
    ring = np.stack([np.cos(u), np.sin(u)], -1)
    side = np.concatenate([np.stack([r * ring[:, 0], np.full(segments, h), r * ring[:, 1]], -1)
                           for r, h in profile])
    bottom = len(side)
    top = bottom + 1
    vertices = np.concatenate([side, [[0, profile[0, 1], 0], [0, profile[-1, 1], 0]]])
    faces = [_grid_faces(len(profile), segments)]
    last = (len(profile) - 1) * segments
    faces.append(np.asarray([(bottom, j, (j + 1) % segments) for j in range(segments)], np.uint32))
    faces.append(np.asarray([(top, last + (j + 1) % segments, last + j) for j in range(segments)], np.uint32))
    return vertices.astype(np.float32), np.concatenate(faces).astype(np.uint32)


def cone(radius: float = 0.5, height: float = 1.0, segments: int = 32):
    """Cone standing on y = -height/2, apex up."""
    return _lathe(np.array([[radius, -height / 2], [1e-3, height / 2]]), segments)


def pyramid(base: float = 1.0, height: float = 0.9):
    """Square pyramid (a lathe of 4 segments)."""
    return _lathe(np.array([[base / np.sqrt(2), -height / 2], [1e-3, height / 2]]), 4)


def prism(sides: int = 6, radius: float = 0.5, height: float = 1.0):
    """Upright n-gon prism (a lathe with few segments)."""
    return _lathe(np.array([[radius, -height / 2], [radius, height / 2]]), sides)


def vase(rng: np.random.Generator, segments: int = 32):
    """A random smooth vase-like surface of revolution."""
    heights = np.linspace(-0.5, 0.5, 9)
    radii = 0.15 + 0.3 * np.abs(np.cumsum(rng.normal(0, 0.35, heights.size))) / 2
    return _lathe(np.stack([np.clip(radii, 0.05, 0.5), heights], -1), segments)


def blob(rng: np.random.Generator, subdivisions: int = 24):
    """A lumpy closed surface: a UV sphere displaced by a few random low-order waves."""
    theta = np.linspace(1e-3, np.pi - 1e-3, subdivisions)
    phi = np.linspace(0, 2 * np.pi, 2 * subdivisions, endpoint=False)
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    radius = 0.5 * np.ones_like(tt)
    for _ in range(3):
        radius += rng.uniform(0.02, 0.08) * np.sin(rng.integers(1, 4) * tt + rng.uniform(0, 6)) \
            * np.cos(rng.integers(1, 4) * pp + rng.uniform(0, 6))
    vertices = np.stack([radius * np.sin(tt) * np.cos(pp), radius * np.cos(tt),
                         radius * np.sin(tt) * np.sin(pp)], -1).reshape(-1, 3)
    cols = 2 * subdivisions
    faces = [_grid_faces(subdivisions, cols)[:, [0, 2, 1]]]
    top, bottom = len(vertices), len(vertices) + 1
    last = (subdivisions - 1) * cols
    faces.append(np.asarray([(top, (j + 1) % cols, j) for j in range(cols)], np.uint32))
    faces.append(np.asarray([(bottom, last + j, last + (j + 1) % cols) for j in range(cols)], np.uint32))
    vertices = np.concatenate([vertices, [[0, 0.5, 0], [0, -0.5, 0]]])
    return vertices.astype(np.float32), np.concatenate(faces).astype(np.uint32)


def to_mitsuba(name: str, vertices: np.ndarray, faces: np.ndarray, bsdf: dict, to_world=None):
    """An ``mi.Mesh`` with the given BSDF (a ``load_dict`` description) and transform."""
    import mitsuba as mi

    if to_world is not None:
        matrix = np.asarray(to_world.matrix, np.float64).reshape(4, 4)
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh(name, len(vertices), len(faces), props=props)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(vertices, np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(faces, np.uint32).ravel())
    params.update()
    return mesh
