"""Generate the procedural texture(s) used by ``scene.xml`` (made for gmcpt).

Writes ``wood.png`` next to this script: a 256x256, seamlessly tiling,
8-bit sRGB image of wooden floor planks (streaky grain, per-plank tone
variation and dark seams). The output is deterministic (fixed RNG seed),
so re-running the script reproduces the committed file.

Usage::

    python scenes/still-life/make_textures.py
"""

from pathlib import Path

import numpy as np

SIZE = 256
N_PLANKS = 4          # planks across the tile (along v)
SEED = 7


def periodic_noise(rng, u, v, n_terms, max_freq, amp_decay=1.0):
    """Sum of random sinusoids with integer frequencies, hence tileable in u, v."""
    out = np.zeros_like(u)
    for _ in range(n_terms):
        fu = rng.integers(0, max_freq + 1)
        fv = rng.integers(0, max_freq + 1)
        if fu == 0 and fv == 0:
            continue
        phase = rng.uniform(0, 2 * np.pi)
        amp = 1.0 / (1.0 + np.hypot(fu, fv)) ** amp_decay
        out += amp * np.sin(2 * np.pi * (fu * u + fv * v) + phase)
    return out / (np.abs(out).max() + 1e-8)


def make_wood(size=SIZE, seed=SEED):
    rng = np.random.default_rng(seed)
    t = (np.arange(size) + 0.5) / size
    u, v = np.meshgrid(t, t, indexing="xy")  # u: along the planks, v: across

    plank = np.floor(v * N_PLANKS).astype(int)
    local_v = v * N_PLANKS - plank          # 0..1 inside a plank

    # Grain: stretched, warped stripes running along u.
    # Each plank gets its own u-shift of the warp field and grain phase, so
    # the pattern does not run continuously across the seams.
    shift = rng.uniform(0, 1, size=N_PLANKS)[plank]
    phase = rng.uniform(0, 2 * np.pi, size=N_PLANKS)[plank]
    freq = rng.integers(4, 9, size=N_PLANKS)[plank]
    warp = 0.35 * periodic_noise(rng, (u + shift) % 1.0, v, 24, 3)
    fine = periodic_noise(rng, u, v, 40, 12, amp_decay=0.5)
    grain = np.sin(2 * np.pi * (freq * local_v + 2.0 * warp) + 0.6 * fine + phase)
    grain = 0.5 + 0.5 * grain
    grain = grain ** 3                       # thin dark late-wood lines

    # Per-plank tone (and a per-plank offset of the grain strength).
    tone = rng.uniform(0.8, 1.15, size=N_PLANKS)[plank]
    strength = rng.uniform(0.25, 0.45, size=N_PLANKS)[plank]

    light = np.array([0.80, 0.58, 0.36])
    dark = np.array([0.45, 0.27, 0.13])
    mix = (1.0 - strength * (1.0 - grain))[..., None]
    col = dark + (light - dark) * mix
    col = col * tone[..., None]

    # Small per-pixel speckle for texture detail.
    col *= (1.0 + 0.04 * rng.standard_normal((size, size, 1)))

    # Dark seams between planks (periodic, so tiles cleanly).
    seam = np.minimum(local_v, 1.0 - local_v) * size / N_PLANKS
    col *= np.clip(0.35 + 0.65 * seam / 1.5, 0.35, 1.0)[..., None]

    # End joints at staggered positions along u.
    joint_u = rng.uniform(0, 1, size=N_PLANKS)[plank]
    du = np.abs(((u - joint_u + 0.5) % 1.0) - 0.5) * size
    col *= np.clip(0.4 + 0.6 * du / 1.2, 0.4, 1.0)[..., None]

    return np.clip(col, 0.0, 1.0)


def write_png(path, rgb):
    """Write an sRGB 8-bit PNG (values in ``rgb`` are already display-encoded)."""
    data = np.round(rgb * 255.0).astype(np.uint8)
    try:
        from PIL import Image

        Image.fromarray(data, "RGB").save(path, optimize=True)
    except ImportError:  # fall back to Mitsuba's own image I/O
        import mitsuba as mi

        mi.set_variant("scalar_rgb")
        bmp = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.RGB)
        bmp.set_srgb_gamma(True)
        bmp.write(str(path))


def main():
    out = Path(__file__).resolve().parent / "wood.png"
    write_png(out, make_wood())
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    main()
