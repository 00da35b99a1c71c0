"""The evaluation's figures (matplotlib, PNG), each written atomically."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..image.metrics import flip_map, tonemap
from ..io.exr import atomic_output
from .config import DEFAULT_VARIANT
from .report import BASELINES, best_within, contender_name, contenders, groups, in_group, one_spp_seconds

#: the at-a-glance plot: PSNR against time, one panel per group of scenes (real, synthetic)
GROUPS_PLOT = "psnr_vs_time_groups.png"

STYLE = {"path": ("tab:gray", "o"), "path+oidn": ("tab:blue", "s"), "adaptive+oidn": ("navy", "D"),
         "pawnnm": ("tab:orange", "^"),
         "gan_pawnnm": ("tab:red", "v"), "interp": ("tab:olive", "x"), "liu": ("tab:purple", "d"),
         "nnm": ("tab:brown", "<"), "gan": ("tab:pink", ">"), "gan_oidn": ("tab:green", "*"),
         "gan_pawnnm_oidn": ("tab:cyan", "P")}


def _figure(columns: int, panels: int, size=(4.2, 3.4)):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = -(-panels // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(size[0] * columns, size[1] * rows), squeeze=False,
                                layout="constrained")
    for axis in axes.flat[panels:]:
        axis.axis("off")
    return figure, list(axes.flat)


def _save(figure, path: Path) -> None:
    import matplotlib.pyplot as plt

    with atomic_output(path) as temporary:
        figure.savefig(temporary, format="png", dpi=110)  # the constrained layout already fits the labels
    plt.close(figure)


def _frontier(points: list[tuple[float, float]], end: float) -> tuple[list[float], list[float]]:
    """The best PSNR reachable within each time up to ``end``: a staircase through the non-dominated points."""
    xs, ys, best = [], [], -np.inf
    for x, y in sorted(points):
        if y > best:
            xs.append(x)
            ys.append(y)
            best = y
    return xs + [end], ys + ys[-1:]


def psnr_vs_time(rows: list[dict], path: Path) -> None:
    """Per scene: PSNR against total wall time of every measured setting (markers) and, as a staircase, the best
    PSNR each contender reaches within a given time."""
    from matplotlib.ticker import NullFormatter

    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    figure, axes = _figure(min(3, len(scenes)), len(scenes))
    for axis, scene in zip(axes, scenes):
        end = max(r["seconds"] for r in rows if r["scene"] == scene)
        for name in contenders(rows):
            chosen = [r for r in rows if r["scene"] == scene and r["contender"] == name]
            color, marker = STYLE.get(name, ("black", "."))
            points = [(r["seconds"], r["psnr"]) for r in chosen]
            axis.scatter(*zip(*points), color=color, marker=marker, s=18, alpha=0.5)
            axis.plot(*_frontier(points, end), color=color, drawstyle="steps-post", label=contender_name(name))
        axis.set_xscale("log")
        axis.xaxis.set_minor_formatter(NullFormatter())
        axis.set_title(scene)
        axis.set_xlabel("wall time, s (log)")
        axis.set_ylabel("PSNR dB")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    _save(figure, path)


def group_curves(rows: list[dict], where: dict, names: list[str], points: int = 48) -> dict:
    """contender -> (times, mean PSNR): over the scenes of one group (:func:`groups`), the best PSNR each of ``names``
    reaches within each time, time in units of each scene's 1-spp render (scenes differ 30-fold in speed, so seconds
    would not average); a time where some scene has no setting that fits is left out."""
    scenes = in_group(rows, where)
    unit = {s: one_spp_seconds(rows, s) for s in scenes}
    end = max(r["seconds"] / unit[r["scene"]] for r in rows if r["scene"] in unit)
    grid = np.geomspace(1.0, end, points)
    curves = {}
    for name in names:
        xs, ys = [], []
        for budget in grid:
            best = [best_within([r for r in rows if r["scene"] == s], name, "seconds", budget * unit[s]) for s in scenes]
            if all(b is not None for b in best):
                xs.append(float(budget))
                ys.append(float(np.mean([b["psnr"] for b in best])))
        if xs:
            curves[name] = (xs, ys)
    return curves


def psnr_vs_time_groups(rows: list[dict], path: Path, names=(*BASELINES, DEFAULT_VARIANT)) -> None:
    """One panel per group of scenes (the real and the synthetic means; the mean of all without real scenes): the
    mean best PSNR of each of ``names`` within a time (:func:`group_curves`; by default the baselines and the
    default: path tracing without a denoiser would stretch the axis ten-fold)."""
    from matplotlib.ticker import NullFormatter

    chosen = [(label, where) for label, where in groups(rows) if "scene" not in where]
    chosen = [group for group in chosen if group[1]] or chosen  # the overall mean only where it is the only one
    figure, axes = _figure(len(chosen), len(chosen))
    for axis, (label, where) in zip(axes, chosen):
        for name, (xs, ys) in group_curves(rows, where, list(names)).items():
            color, marker = STYLE.get(name, ("black", "."))
            axis.plot(xs, ys, color=color, drawstyle="steps-post",
                      label=f"default ({name})" if name == DEFAULT_VARIANT else contender_name(name))
        axis.set_xscale("log")
        axis.xaxis.set_minor_formatter(NullFormatter())
        axis.set_title(label.strip("*"))
        axis.set_xlabel("wall time, x the scene's 1-spp render (log)")
        axis.set_ylabel("mean PSNR dB")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    _save(figure, path)


def write_plots(record: dict, out: Path) -> None:
    """The plots that are functions of an evaluation's rows (the image grids need its images)."""
    psnr_vs_time(record["equal_time"], out / "psnr_vs_time.png")
    psnr_vs_time_groups(record["equal_time"], out / GROUPS_PLOT)
    psnr_vs_rate(record["quality"], list(record["config"]["variants"]), out / "psnr_vs_rate.png")


def psnr_vs_rate(rows: list[dict], variants: list[str], path: Path) -> None:
    """Per scene and on average: PSNR against sampling rate for each completion variant."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    figure, axes = _figure(min(3, len(scenes) + 1), len(scenes) + 1)
    for axis, scene in zip(axes, scenes + [None]):
        for variant in variants:
            chosen = [r for r in rows if r["variant"] == variant and (scene is None or r["scene"] == scene)]
            if not chosen:
                continue
            rates = sorted({r["rate"] for r in chosen})
            psnr = [np.mean([r["psnr"] for r in chosen if r["rate"] == rate]) for rate in rates]
            color, marker = STYLE.get(variant, ("black", "."))
            axis.plot(rates, psnr, color=color, marker=marker, label=variant)
        axis.set_title(scene or f"mean of {len(scenes)} scenes")
        axis.set_xlabel("sampling rate")
        axis.set_ylabel("PSNR dB")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    _save(figure, path)


def image_grid(images: dict, path: Path, title: str) -> None:
    """Top row: reference, sparse input and each method's image; bottom row: their FLIP error maps."""
    reference = images["reference"]
    labels = [label for label in images if label != "reference"]
    figure, axes = _figure(len(labels) + 1, 2 * (len(labels) + 1), size=(2.3, 2.5))
    columns = len(labels) + 1
    axes[0].imshow(tonemap(reference))
    axes[0].set_title("reference", fontsize=8)
    axes[columns].axis("off")
    for index, label in enumerate(labels, 1):
        error, mean = flip_map(images[label], reference)
        axes[index].imshow(tonemap(images[label]))
        axes[index].set_title(label, fontsize=8)
        axes[columns + index].imshow(error, cmap="magma", vmin=0, vmax=1)
        axes[columns + index].set_title(f"FLIP {mean:.3f}", fontsize=8)
    for axis in axes:
        axis.set_xticks([])
        axis.set_yticks([])
    figure.suptitle(title, fontsize=9)
    _save(figure, path)


SEQUENCE_STYLE = {"path+oidn": ("tab:blue", "s"), "lightpath+oidn": ("tab:cyan", "v"),
                  "accumulation+oidn": ("tab:purple", "D"), "sequence": ("tab:green", "*")}


def sequence_plot(rows: list[dict], path: Path, settings: dict | None = None) -> None:
    """Per (scene, motion) of a sequence benchmark (``benchmarks/sequence.py``): mean PSNR against mean seconds a
    frame, and the ceiling (:func:`gmcpt.evaluation.sequences.ceiling`): what path tracing + OIDN reaches at
    :data:`~gmcpt.evaluation.sequences.CEILING_SAMPLES` x the sequence's samples, dashed at the sequence's seconds. ``settings``: the record's, for the motion
    of rows from before the benchmark ran several."""
    from matplotlib.ticker import NullFormatter

    from .sequences import CEILING_SAMPLES, ceiling, groups, motion_of

    panels = groups(rows, settings)
    figure, axes = _figure(min(3, len(panels)), len(panels))
    for axis, (scene, motion) in zip(axes, panels):
        chosen = [r for r in rows if r["scene"] == scene and motion_of(r, settings or {}) == motion]
        for contender, (color, marker) in SEQUENCE_STYLE.items():
            points = sorted((r["seconds"], r["psnr"]) for r in chosen if r["contender"] == contender)
            if points:
                axis.plot(*zip(*points), color=color, marker=marker, label=contender)
        top = ceiling(chosen)
        if top:
            axis.plot(*zip(*top), color=SEQUENCE_STYLE["path+oidn"][0], linestyle="--",
                      label=f"ceiling: path+oidn at {CEILING_SAMPLES:g}x samples")
        axis.set_xscale("log")
        axis.xaxis.set_minor_formatter(NullFormatter())
        axis.set_title(f"{scene}, {motion}", fontsize=9)
        axis.set_xlabel("seconds a frame (warm)")
        axis.set_ylabel("PSNR dB")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    _save(figure, path)
