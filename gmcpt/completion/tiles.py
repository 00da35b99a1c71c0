"""Completion over overlapping tiles: time and memory that grow linearly with the frame.

A frame larger than the tile is cut into overlapping tiles (every tile the same
size, the overlaps spread evenly), each tile is completed on its own, and the
results are blended with weights that ramp linearly across each overlap, so
neighbouring tiles cross-fade instead of meeting at a seam. Depth keeps the
frame's normalisation (a tile is a crop of the frame's buffers).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from ..frame import PIXEL_BUFFERS, SparseFrame

#: Default overlap between neighbouring tiles, in pixels: a few patches of the matching stage.
DEFAULT_OVERLAP = 32
#: the smallest tile: twice the overlap, so that a tile is more than its blended edges
MIN_TILE = 2 * DEFAULT_OVERLAP
#: Default largest tile side of the command line and ``masked_path``: frames up to 1024x1024 complete
#: whole; larger ones in tiles, so memory stays bounded (0: always the whole frame).
DEFAULT_TILE = 1024


def check_tile(tile: int) -> int:
    """``tile`` as an int: 0 (the whole frame) or a side of at least twice the overlap; else one-line error."""
    from ..errors import GmcptError

    if isinstance(tile, bool) or int(tile) != tile or (tile != 0 and tile < MIN_TILE):
        raise GmcptError(f"tile must be 0 (the whole frame) or at least {MIN_TILE} pixels, got {tile}")
    return int(tile)


def tile_spans(length: int, tile: int, overlap: int) -> list[tuple[int, int]]:
    """``(start, stop)`` of the fewest tiles of side at most ``tile`` that cover ``[0, length)`` overlapping by
    at least ``overlap``.

    One span when the frame fits in a tile. The tiles share one side, the smallest that gives that
    overlap (so little is completed twice), and their starts are spread evenly.
    """
    if tile <= overlap:
        raise ValueError(f"tile ({tile}) must be larger than the overlap ({overlap})")
    if length <= tile:
        return [(0, length)]
    count = -(-(length - overlap) // (tile - overlap))
    side = -(-(length + (count - 1) * overlap) // count)
    starts = np.round(np.linspace(0, length - side, count)).astype(int)
    return [(int(start), int(start) + side) for start in starts]


def _ramp(spans: list[tuple[int, int]], index: int, length: int) -> np.ndarray:
    """Weights along one axis of tile ``index``: 1 inside, rising linearly across the overlaps with its neighbours."""
    start, stop = spans[index]
    weight = np.ones(stop - start, np.float32)
    if index > 0:  # overlap with the previous tile: [start, previous stop)
        width = spans[index - 1][1] - start
        weight[:width] = np.minimum(weight[:width], (np.arange(width) + 0.5) / width)
    if index + 1 < len(spans):  # overlap with the next tile: [next start, stop)
        width = stop - spans[index + 1][0]
        weight[-width:] = np.minimum(weight[-width:], (width - np.arange(width) - 0.5) / width)
    return weight


def crop_frame(frame: SparseFrame, rows: slice, columns: slice) -> SparseFrame:
    """The part of ``frame`` in ``rows`` x ``columns`` (views of its buffers)."""
    buffers = {name: getattr(frame, name)[rows, columns] for name in PIXEL_BUFFERS if getattr(frame, name) is not None}
    return dataclasses.replace(frame, **buffers)


def complete_in_tiles(frame: SparseFrame, complete_tile: Callable[[SparseFrame], object], tile: int,
                      overlap: int = DEFAULT_OVERLAP, progress: Callable[[str], None] | None = None
                      ) -> tuple[np.ndarray, dict]:
    """Complete ``frame`` tile by tile with ``complete_tile`` (a frame -> :class:`Completion` function).

    Returns the blended (H, W, 3) float32 image and the tiles' timings summed per sub-stage.
    """
    height, width = frame.shape
    row_spans, column_spans = tile_spans(height, tile, overlap), tile_spans(width, tile, overlap)
    image = np.zeros((height, width, 3), np.float32)
    total_weight = np.zeros((height, width, 1), np.float32)
    timings: dict = {}
    count = len(row_spans) * len(column_spans)
    for row_index, (top, bottom) in enumerate(row_spans):
        for column_index, (left, right) in enumerate(column_spans):
            if progress:
                progress(f"completion: tile {row_index * len(column_spans) + column_index + 1}/{count}")
            result = complete_tile(crop_frame(frame, slice(top, bottom), slice(left, right)))
            weight = np.outer(_ramp(row_spans, row_index, height), _ramp(column_spans, column_index, width))
            image[top:bottom, left:right] += result.image * weight[..., None]
            total_weight[top:bottom, left:right] += weight[..., None]
            for name, seconds in result.timings.items():
                timings[name] = timings.get(name, 0.0) + seconds
    return image / total_weight, timings
