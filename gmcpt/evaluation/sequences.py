"""The figures of the sequence benchmark's record (``benchmarks/sequence.py --record``) as pure functions of its rows:
what the benchmark prints, the plot draws and ``docs/results.md`` states all come from here, so that they agree.

A row is one contender at one setting on one (scene, motion): ``contender`` (``path+oidn``, ``accumulation+oidn``,
``sequence``), ``spp`` (samples a pixel a frame), ``seconds`` (warm, a frame), ``psnr`` and the other figures.
"""
from __future__ import annotations

import numpy as np

#: The motions in which the camera moves; in the others (``object``, ``light``) the scene changes under a still
#: camera, where history goes stale without any reprojection to tell.
CAMERA_MOTIONS = ("pan", "dolly")
#: What moves in each motion of the benchmark, in words (its record says what moved in each scene).
MOTION_WORDS = {"pan": "The camera turns about its own up axis", "dolly": "The camera moves along its view",
                "object": "The camera stays; an object slides across the room, its shadow with it",
                "light": "The camera stays; the scene's main light turns about the vertical through the scene's "
                         "centre, as the sun does, its patches and shadows with it",
                "still": "Nothing moves"}
#: The plot's ceiling, as issue 75 sets it: path tracing + OIDN at this many times the sequence's samples a pixel a
#: frame, the quality that reusing earlier frames' samples is held against.
CEILING_SAMPLES = 7.6


def motion_of(row: dict, settings: dict) -> str:
    """A row's motion; records from before the benchmark ran several motions had one, in their settings."""
    ran = settings.get("motion", "pan")
    return row.get("motion") or (ran if isinstance(ran, str) else ran[0])


def motions(sequences: dict) -> list[str]:
    """The motions of a record, in the order the benchmark ran them (its ``--motion``), then any other its rows or
    verdicts have."""
    settings = sequences["settings"]
    ran = settings.get("motion", "pan")
    found = [motion_of(item, settings) for item in sequences["rows"] + sequences["verdicts"]]
    return list(dict.fromkeys(([ran] if isinstance(ran, str) else list(ran)) + found))


def groups(rows: list[dict], settings: dict | None = None) -> list[tuple[str, str]]:
    """The (scene, motion) pairs of ``rows``, in their order."""
    return list(dict.fromkeys((r["scene"], motion_of(r, settings or {})) for r in rows))


def at_equal_time(rows: list[dict], baseline: str, figure: str) -> list[tuple[float, float]]:
    """For each sequence row with ``figure``: (its figure, ``baseline``'s at the same seconds a frame), the
    baseline's interpolated in log time between its settings and held at its ends. Rows of one (scene, motion)."""
    points = sorted((r["seconds"], r[figure]) for r in rows if r["contender"] == baseline and r.get(figure) is not None)
    if not points:
        return []
    times, values = np.log([p[0] for p in points]), [p[1] for p in points]
    return [(r[figure], float(np.interp(np.log(r["seconds"]), times, values)))
            for r in rows if r["contender"] == "sequence" and r.get(figure) is not None]


def equal_time_ratio(rows: list[dict], baseline: str, figure: str = "flicker") -> float | None:
    """Geometric mean over the sequence's settings of its ``figure`` over ``baseline``'s at the same seconds a
    frame (:func:`at_equal_time`): below 1 the sequence flickers less. None where either has no figure."""
    pairs = at_equal_time(rows, baseline, figure)
    return float(np.exp(np.mean([np.log(mine / theirs) for mine, theirs in pairs]))) if pairs else None


def equal_time_gap(rows: list[dict], baseline: str, figure: str = "psnr_changed") -> float | None:
    """Mean over the sequence's settings of its ``figure`` (dB) minus ``baseline``'s at the same seconds a frame
    (:func:`at_equal_time`): negative where the sequence is behind. None where either has no figure."""
    pairs = at_equal_time(rows, baseline, figure)
    return float(np.mean([mine - theirs for mine, theirs in pairs])) if pairs else None


def ceiling(rows: list[dict], factor: float = CEILING_SAMPLES) -> list[tuple[float, float]]:
    """(seconds a frame, PSNR) for each sequence row: the PSNR path tracing + OIDN reaches at ``factor`` x the
    sequence's samples a pixel (interpolated in log samples between its settings, held at its ends), drawn at the
    sequence's seconds. Rows of one (scene, motion); empty without both."""
    points = sorted((r["spp"], r["psnr"]) for r in rows if r["contender"] == "path+oidn")
    if not points:
        return []
    samples, values = np.log([p[0] for p in points]), [p[1] for p in points]
    return sorted((r["seconds"], float(np.interp(np.log(factor * r["spp"]), samples, values)))
                  for r in rows if r["contender"] == "sequence")


def _span(values: list[float], form: str) -> str:
    """``1.2-1.9x`` of ``values`` (one value alone)."""
    low, high = min(values), max(values)
    return f"{low:{form}}x" if f"{low:{form}}" == f"{high:{form}}" else f"{low:{form}}-{high:{form}}x"


def glance_line(sequences: dict) -> str:
    """One line on the sequence mode's verdicts from the benchmark's record: its speed-up at equal quality over
    per-frame path tracing + OIDN (the yardstick) on camera motion and on moving objects and lights, its flicker
    over that baseline's at equal time, and its speed-up over accumulation + OIDN."""
    settings, verdicts = sequences["settings"], sequences["verdicts"]

    def spans(baseline: str) -> list[str]:
        said = []
        for label, chosen in (("on pans and dollies", lambda motion: motion in CAMERA_MOTIONS),
                              ("on moving objects and lights", lambda motion: motion in ("object", "light"))):
            speedups = [v["speedup"] for v in verdicts
                        if v["baseline"] == baseline and chosen(motion_of(v, settings))]
            if speedups:
                said.append(f"{_span(speedups, '.2f')} {label}")
        return said

    flicker = [v["flicker_ratio"] for v in verdicts
               if v["baseline"] == "path+oidn" and v.get("flicker_ratio") is not None]
    accumulation = spans("accumulation+oidn")
    return (f"**Sequences** (`benchmarks/sequence.py`, {len({v['scene'] for v in verdicts})} scenes at "
            f"{settings['res']}x{settings['res']}): the sequence mode's speed-up at equal quality over per-frame path "
            f"tracing + OIDN is {'; '.join(spans('path+oidn')) or 'not measured'} (above 1x it is faster)"
            + (f", its flicker {_span(flicker, '.2f')} of that baseline's at equal time" if flicker else "")
            + (f"; over accumulation + OIDN {'; '.join(accumulation)}" if accumulation else "")
            + " (*Sequences* below).")
