"""Temporal gradients (after A-SVGF): where a still camera's light changed, read from a few pixels traced twice with
the same random numbers, once in each of two frames.

Each frame of a sequence traces one sample of one pixel in every :data:`STRATUM` x :data:`STRATUM` block of its film
ahead of its other samples, in the first lanes of its pass with a seed of their own (a :class:`Probe`), as part of
its budget. The next frame, if its camera has not moved, traces the same pixels in the same lanes with the same seed
in its one pass (its own probe in the other lanes ahead; a sampler's lane draws from its seed and its index alone):
where nothing changed along a path the two samples are equal to the bit, and where a light moved, switched or dimmed,
or an object's shadow moved, they differ by what changed along it, the light it brings indirectly included. The
lighting signature (:func:`gmcpt.temporal.history.unchanged`) sees only the light a surface gets directly: on the
breakfast room's turning sun the pixels whose image changed most had a signature of 0 in both frames, their history
kept, and showed the last frame's light (docs/experiments.md).

:func:`changed_share` reads the probes' differences over a neighbourhood of blocks against the larger of each pair of
samples: the share of the light that changed there, 0 where no path changed (the samples agree to the bit), 1 where a
light went out. The history's weight is scaled by what stayed (1 - the share). The differences are taken unsigned: a
light that moved brightens one bounce and darkens another nearby, and signed differences cancelled there. The carry
of the frame shown before is not scaled by it (that added 3-35% to the flicker of a turning sky or sun), but a pixel
whose light the probes saw hold keeps its carry where the frame-wide share of changed light would take it
(:data:`gmcpt.temporal.sequence.CARRY_HELD_POWER`; docs/experiments.md).

:func:`coherent_share` reads the same differences signed, less their noise: under a light that moved, the same random
numbers are another sample wherever a shadow ray's answer flips, and the unsigned share reads path noise as change (a
third of the living room's pixels under its moving lamp). Noise flips both ways and its sum grows as the root of the
probes' count; a shadow's edge or a sun patch that moved changes its neighbourhood one way. The placement reads it to
give the pixels whose light keeps changing fresh samples first (:data:`gmcpt.temporal.sequence.LIGHT_PLACEMENT_POWER`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .history import box_sum

#: Probes are one pixel in each block of this many pixels a side (a ninth of the pixels: 1/9 of a sample a pixel
#: a frame, traced within the budget).
STRATUM = 3
#: Blocks either side of a block whose probes' differences are pooled: 5x5 blocks, 15x15 pixels (the agreement
#: test's neighbourhood; docs/experiments.md).
GRADIENT_RADIUS = 2
#: :func:`coherent_share` counts what the probes' signed sum holds beyond this many times its noise (1.5 left the
#: breakfast room's sun patch a ghost of -0.5 dB; docs/experiments.md, sixty-fifth session).
NOISE_MARGIN = 1.0


@dataclass(frozen=True)
class Probe:
    """One sample of each of a frame's probe ``pixels`` (K,) flat, traced with ``seed`` in lanes ``slot`` x K to
    (``slot`` + 1) x K of its pass: ``values`` (K, 3) (NaN where the sample was not finite); ``index``: the frame;
    ``matrix``: its camera's projection (a probe replays only for a camera that stayed); ``shape``: its film's (H, W).
    The next frame's probe takes the other slot, its replay this one."""

    index: int
    seed: int
    pixels: np.ndarray
    values: np.ndarray
    matrix: np.ndarray
    shape: tuple[int, int]
    slot: int = 0

    def replays_in(self, index: int, matrix: np.ndarray, shape: tuple[int, int]) -> bool:
        """Whether frame ``index`` (camera ``matrix``, film ``shape``) is the next frame, its camera where this
        probe's was."""
        return self.index == index - 1 and tuple(self.shape) == tuple(shape) and same_camera(self.matrix, matrix)


def same_camera(matrix: np.ndarray, other: np.ndarray) -> bool:
    """Whether two cameras' 3x4 projections are the same camera (up to the rounding of a camera set again)."""
    return bool(np.allclose(matrix, other, rtol=1e-6, atol=1e-9))


def probe_pixels(shape: tuple[int, int], seed: int, avoid: np.ndarray | None = None) -> np.ndarray:
    """One pixel (flat) of each whole :data:`STRATUM`-wide block of a ``shape`` (H, W) film, at random within it,
    never the block's pixel in ``avoid`` (the last probe's: its pixels get their sample from the replay)."""
    height, width = shape
    rows, columns = height // STRATUM, width // STRATUM
    if not rows or not columns:
        return np.zeros(0, np.int64)
    rng = np.random.default_rng(seed)
    cells = STRATUM * STRATUM
    if avoid is not None and avoid.size == rows * columns:
        y, x = np.divmod(avoid, width)
        offset = (y % STRATUM * STRATUM + x % STRATUM).reshape(rows, columns)
        offset = (offset + 1 + rng.integers(0, cells - 1, (rows, columns))) % cells
    else:
        offset = rng.integers(0, cells, (rows, columns))
    y = np.arange(rows)[:, None] * STRATUM + offset // STRATUM
    x = np.arange(columns)[None, :] * STRATUM + offset % STRATUM
    return (y * width + x).ravel().astype(np.int64)


def changed_share(before: np.ndarray, after: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The share of the light that changed at each pixel of a ``shape`` (H, W) film (N,) float32 in [0, 1], from a
    probe's samples ``before`` and their replay ``after`` (K, 3) each: over the :data:`GRADIENT_RADIUS` blocks around
    a pixel's block, the sum of the luminance differences' sizes over the sum of the larger luminance of each pair.
    Pixels past the last whole block read the nearest one's; a pair with a non-finite sample counts as no probe."""
    return _share(before, after, shape, lambda differences: box_sum(np.abs(differences), GRADIENT_RADIUS))


def coherent_share(before: np.ndarray, after: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """As :func:`changed_share`, but the changed light over the blocks around a pixel's block is the size of the
    differences' signed sum less :data:`NOISE_MARGIN` x the root of their squares' sum (at least 0): what changed one
    way there, beyond the paths that changed at random."""
    def changed(differences: np.ndarray) -> np.ndarray:
        noise = np.sqrt(np.maximum(box_sum(differences * differences, GRADIENT_RADIUS), 0.0))  # the table's rounding
        return np.maximum(np.abs(box_sum(differences, GRADIENT_RADIUS)) - NOISE_MARGIN * noise, 0.0)
    return _share(before, after, shape, changed)


def _share(before: np.ndarray, after: np.ndarray, shape: tuple[int, int], changed) -> np.ndarray:
    """``changed`` (of the blocks' luminance differences, (rows, columns)) over the pooled larger luminances, by
    pixel (:func:`changed_share`)."""
    height, width = shape
    rows, columns = height // STRATUM, width // STRATUM
    if not rows or not columns:
        return np.zeros(height * width, np.float32)
    valid = np.isfinite(before).all(axis=1) & np.isfinite(after).all(axis=1)
    old = np.where(valid, np.maximum(np.nan_to_num(before).mean(axis=1), 0.0), 0.0)
    new = np.where(valid, np.maximum(np.nan_to_num(after).mean(axis=1), 0.0), 0.0)
    difference = changed((new - old).reshape(rows, columns).astype(np.float64))
    larger = box_sum(np.maximum(new, old).reshape(rows, columns).astype(np.float64), GRADIENT_RADIUS)
    share = np.where(larger > 0, difference / np.where(larger > 0, larger, 1.0), 0.0)
    row = np.minimum(np.arange(height) // STRATUM, rows - 1)
    column = np.minimum(np.arange(width) // STRATUM, columns - 1)
    return np.clip(share[row[:, None], column[None, :]], 0.0, 1.0).astype(np.float32).ravel()
