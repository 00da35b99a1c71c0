"""Procedural textures and environment maps made with numpy.

Every function takes a :class:`numpy.random.Generator` and returns a float32
``(H, W, 3)`` array in linear RGB; :func:`to_bitmap` wraps one for Mitsuba.
Textures are small (64-256 px) and repeat through ``to_uv`` scaling in the
scene generator, so a scene stays cheap to build.
"""
from __future__ import annotations

import numpy as np


def random_color(rng: np.random.Generator, low: float = 0.05, high: float = 0.9) -> np.ndarray:
    """A random RGB reflectance: a hue-ish mix, brightness in [low, high]."""
    base = rng.dirichlet([1.5, 1.5, 1.5])
    saturation = rng.uniform(0.0, 1.0)
    color = (1 - saturation) + saturation * 3 * base
    color = color / max(color.max(), 1e-6) * rng.uniform(low, high)
    return np.clip(color, 0.0, 1.0).astype(np.float32)


def checkerboard(rng: np.random.Generator, size: int = 64) -> np.ndarray:
    """Two-colour checkerboard with 2-8 cells per side."""
    cells = int(rng.integers(2, 9))
    y, x = np.mgrid[0:size, 0:size] * cells // size
    a, b = random_color(rng), random_color(rng)
    return np.where(((x + y) % 2 == 0)[..., None], a, b).astype(np.float32)


def stripes(rng: np.random.Generator, size: int = 64) -> np.ndarray:
    """Straight stripes of two colours, random count and duty cycle."""
    count = int(rng.integers(2, 12))
    duty = rng.uniform(0.2, 0.8)
    x = np.linspace(0, count, size, endpoint=False)
    band = (x % 1.0) < duty
    a, b = random_color(rng), random_color(rng)
    row = np.where(band[:, None], a, b)
    return np.broadcast_to(row[None], (size, size, 3)).astype(np.float32).copy()


def value_noise(rng: np.random.Generator, size: int = 128) -> np.ndarray:
    """Smooth tiling noise (sum of random low-frequency Fourier modes) mapped between two colours."""
    freq = np.fft.fftfreq(size) * size
    fy, fx = np.meshgrid(freq, freq, indexing="ij")
    radius = np.hypot(fx, fy)
    spectrum = (rng.standard_normal((size, size)) + 1j * rng.standard_normal((size, size)))
    falloff = np.power(np.maximum(radius, 1.0), -rng.uniform(1.5, 2.5))
    spectrum *= np.where(radius > 0, falloff, 0.0) * (radius < size / 4)
    field = np.real(np.fft.ifft2(spectrum))
    field = (field - field.min()) / max(np.ptp(field), 1e-9)
    a, b = random_color(rng), random_color(rng)
    return (a + (b - a) * field[..., None]).astype(np.float32)


def wood(rng: np.random.Generator, size: int = 128) -> np.ndarray:
    """Ring pattern with noisy distortion: a cheap wood-grain look."""
    y, x = np.mgrid[0:size, 0:size] / size
    warp = value_noise(rng, size)[..., 0]
    rings = np.sin(2 * np.pi * (rng.uniform(4, 14) * np.hypot(x - 0.5, y * 0.15) + 2.0 * warp)) * 0.5 + 0.5
    dark = np.array([0.25, 0.12, 0.05]) * rng.uniform(0.6, 1.2)
    light = np.array([0.6, 0.38, 0.2]) * rng.uniform(0.7, 1.2)
    return np.clip(dark + (light - dark) * rings[..., None], 0, 1).astype(np.float32)


def tiles(rng: np.random.Generator, size: int = 128) -> np.ndarray:
    """Square tiles with thin grout lines and per-tile colour jitter."""
    count = int(rng.integers(3, 9))
    cell = size / count
    y, x = np.mgrid[0:size, 0:size]
    iy, ix = (y // cell).astype(int), (x // cell).astype(int)
    base = random_color(rng, 0.3, 0.9)
    jitter = 1 + 0.15 * rng.standard_normal((count + 1, count + 1, 1))
    image = base * jitter[iy, ix]
    grout = (np.minimum(y % cell, x % cell) < max(1.0, cell * 0.06))[..., None]
    return np.clip(np.where(grout, random_color(rng, 0.05, 0.4), image), 0, 1).astype(np.float32)


TEXTURES = {"checkerboard": checkerboard, "stripes": stripes, "noise": value_noise, "wood": wood,
            "tiles": tiles}


def random_texture(rng: np.random.Generator) -> tuple[str, np.ndarray]:
    """(kind, image) of a random texture kind."""
    kind = str(rng.choice(sorted(TEXTURES)))
    return kind, TEXTURES[kind](rng)


def sky_envmap(rng: np.random.Generator, width: int = 128) -> np.ndarray:
    """Lat-long sky: horizon-to-zenith gradient, darker ground, optional soft sun disc.

    Returned in linear RGB with values around 0.2-2 (the sun up to ~50).
    """
    height = width // 2
    theta = (np.arange(height) + 0.5) / height * np.pi          # 0 = up (+y in Mitsuba's envmap)
    phi = (np.arange(width) + 0.5) / width * 2 * np.pi
    elevation = (np.pi / 2 - theta)[:, None] * np.ones((1, width))
    zenith, horizon = random_color(rng, 0.3, 1.0), random_color(rng, 0.6, 1.0)
    ground = random_color(rng, 0.05, 0.3)
    t = np.clip(elevation / (np.pi / 2), 0, 1)[..., None] ** 0.5
    sky = horizon + (zenith - horizon) * t
    image = np.where((elevation > 0)[..., None], sky, ground).astype(np.float64)
    if rng.random() < 0.6:
        sun_theta, sun_phi = rng.uniform(0.2, 1.3), rng.uniform(0, 2 * np.pi)
        th, ph = np.meshgrid(theta, phi, indexing="ij")
        cosine = (np.sin(th) * np.cos(ph) * np.sin(sun_theta) * np.cos(sun_phi) + np.cos(th) * np.cos(sun_theta)
                  + np.sin(th) * np.sin(ph) * np.sin(sun_theta) * np.sin(sun_phi))
        image += rng.uniform(10, 50) * np.exp((cosine - 1) / 0.0015)[..., None] * np.array([1.0, 0.95, 0.85])
    return image.astype(np.float32)


def to_bitmap(image: np.ndarray):
    """An (H, W, 3) float32 array as a linear-RGB ``mi.Bitmap``."""
    import mitsuba as mi

    return mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32))
