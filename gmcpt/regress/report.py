"""What a check prints, and its HTML report.

:func:`scene_line` is one scene's line (metrics, thresholds, check time beside
the golden's render time, pass or FAIL), :func:`summary` the last line.
:func:`write_html` writes one self-contained page: for each scene the golden,
the check's image and its FLIP error map, as base64 PNGs, failed scenes first.
"""
from __future__ import annotations

import base64
import html
import io
from pathlib import Path

import numpy as np

from .measure import GATES, SceneResult

LABELS = {"flip": "FLIP", "block_psnr": "block PSNR", "psnr": "PSNR", "relmse": "relMSE"}
UNITS = {"block_psnr": " dB", "psnr": " dB"}
FORMATS = {"flip": "{:.4f}", "block_psnr": "{:.2f}", "psnr": "{:.2f}", "relmse": "{:.4f}"}


def metric_text(metric: str, value: float, limit: float | None = None) -> str:
    """``FLIP 0.0812 (<= 0.0950)``: a metric, its value and, for a gated one, its limit."""
    text = f"{LABELS[metric]} {FORMATS[metric].format(value)}{UNITS.get(metric, '')}"
    if limit is not None:
        text += f" ({'<=' if GATES[metric] == 'max' else '>='} {FORMATS[metric].format(limit)})"
    return text


def failure_text(result: SceneResult) -> str:
    """``block PSNR 30.12 dB, threshold >= 37.80``: the gated metrics that failed."""
    return "; ".join(f"{metric_text(metric, result.metrics[metric])}, threshold "
                     f"{'<=' if GATES[metric] == 'max' else '>='} {FORMATS[metric].format(result.thresholds[metric])}"
                     for metric in result.failed)


def scene_line(result: SceneResult, width: int = 16) -> str:
    """One line per scene: name, metrics (thresholds beside the gated ones), times, pass/FAIL/skipped."""
    if result.skipped:
        return f"{result.name:<{width}}  skipped: {result.skipped}"
    parts = [metric_text(metric, result.metrics[metric], result.thresholds.get(metric)) for metric in LABELS]
    times = f"check {result.check_s:.2f} s, golden {result.golden_s:.1f} s"
    return f"{result.name:<{width}}  {'  '.join(parts)}  {times}  {'pass' if result.passed else 'FAIL'}"


def summary(results: list[SceneResult], report: str | None = None) -> str:
    """The last line: counts, the failed scenes, total check time against the goldens' render time."""
    checked = [r for r in results if not r.skipped]
    failed = [r.name for r in checked if not r.passed]
    check_s, golden_s = sum(r.check_s for r in checked), sum(r.golden_s for r in checked)
    text = f"{len(checked)} checked: {len(checked) - len(failed)} passed, {len(failed)} FAILED"
    if failed:
        text += f" ({', '.join(failed)})"
    skipped = len(results) - len(checked)
    if skipped:
        text += f", {skipped} skipped"
    if checked:
        text += f"; check {check_s:.1f} s in all, goldens took {golden_s:.1f} s"
        if golden_s > 0:
            text += f" ({100 * check_s / golden_s:.0f}%)"
    return text + (f"; report {report}" if report else "")


def png_base64(rgb: np.ndarray) -> str:
    """An (H, W, 3) float image in [0, 1] (display values) as base64 PNG text."""
    from matplotlib.image import imsave

    buffer = io.BytesIO()
    imsave(buffer, np.clip(rgb, 0.0, 1.0), format="png")
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def panels(result: SceneResult) -> list[tuple[str, np.ndarray]]:
    """(caption, display image) of a checked scene: golden, check, FLIP error map (magma, 0 to 1)."""
    from matplotlib import colormaps

    from ..image.metrics import tonemap

    error = colormaps["magma"](np.clip(result.flip_map, 0.0, 1.0))[..., :3]
    return [("golden", tonemap(result.golden)), ("check", tonemap(result.image)),
            (f"FLIP error (mean {result.metrics['flip']:.4f})", error)]


def report_order(results: list[SceneResult]) -> list[SceneResult]:
    """Failed scenes first, then passed, then skipped; by name within each."""
    rank = lambda r: (0 if r.skipped is None and r.failed else 1 if r.skipped is None else 2, r.name)  # noqa: E731
    return sorted(results, key=rank)


STYLE = """body{font-family:sans-serif;margin:1.5em;background:#fafafa;color:#222}
section{margin:1em 0;padding:.6em 1em;background:#fff;border-left:6px solid #3a3}
section.fail{border-color:#d22}section.skip{border-color:#aaa}
figure{display:inline-block;margin:.3em .6em .3em 0}figcaption{font-size:85%;color:#555}
img{width:256px;image-rendering:pixelated}table{border-collapse:collapse}td{padding:0 1em 0 0}
.bad{color:#d22;font-weight:bold}"""


def scene_html(result: SceneResult) -> str:
    name = html.escape(result.name)
    if result.skipped:
        return f'<section class="skip"><h2>{name}: skipped</h2><p>{html.escape(result.skipped)}</p></section>'
    status = "pass" if result.passed else "FAIL"
    rows = []
    for metric in LABELS:
        limit = result.thresholds.get(metric)
        bad = metric in result.failed
        limit_text = "" if limit is None else f"{'&le;' if GATES[metric] == 'max' else '&ge;'} " \
                                              f"{FORMATS[metric].format(limit)}"
        rows.append(f'<tr{" class=bad" if bad else ""}><td>{LABELS[metric]}</td>'
                    f"<td>{FORMATS[metric].format(result.metrics[metric])}{UNITS.get(metric, '')}</td>"
                    f"<td>{limit_text}</td></tr>")
    figures = "".join(f'<figure><img alt="{html.escape(caption)}" src="data:image/png;base64,{png_base64(image)}">'
                      f"<figcaption>{html.escape(caption)}</figcaption></figure>" for caption, image in panels(result))
    return (f'<section class="{"pass" if result.passed else "fail"}"><h2>{name}: {status}</h2>'
            f"<table>{''.join(rows)}</table><p>check {result.check_s:.2f} s, golden {result.golden_s:.1f} s</p>"
            f"{figures}</section>")


def html_page(results: list[SceneResult], title: str) -> str:
    """The whole report page (no external files)."""
    body = "".join(scene_html(result) for result in report_order(results))
    return (f"<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{html.escape(title)}</title>"
            f"<style>{STYLE}</style></head><body><h1>{html.escape(title)}</h1>"
            f"<p>{html.escape(summary(results))}</p>{body}</body></html>\n")


def write_html(path: str | Path, results: list[SceneResult], title: str = "gmcpt regression report") -> Path:
    """Write the report to ``path`` atomically."""
    from ..io.files import atomic_output

    with atomic_output(path) as temporary:
        Path(temporary).write_text(html_page(results, title), encoding="utf-8")
    return Path(path)


def composite(result: SceneResult):
    """The report's three panels of ``result`` side by side, (H, 3W + gaps, 3) in [0, 1]."""
    images = [image for _, image in panels(result)]
    gap = np.ones((images[0].shape[0], max(2, images[0].shape[1] // 32), 3), np.float32)
    return np.concatenate([part for image in images for part in (image, gap)][:-1], axis=1)
