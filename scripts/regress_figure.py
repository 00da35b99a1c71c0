"""The README's regression-report figure: docs/images/regress-report.png.

Copies the bundled suite (scenes/ and its goldens) to a temporary folder, turns
the Cornell box's red wall green, checks it with ``--report`` and screenshots
the page's top with a headless Chromium (``chromium-headless-shell`` or
``chromium`` on the PATH). Without one it saves the failed scene's three
report images side by side instead, and says so.

    python scripts/regress_figure.py
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "regress-report.png"
RED, GREEN = "0.63, 0.065, 0.05", "0.14, 0.45, 0.091"


def main() -> int:
    sys.path.insert(0, str(ROOT))
    import gmcpt  # noqa: F401
    import mitsuba as mi
    from matplotlib.image import imsave

    from gmcpt.regress.report import composite, report_order, write_html
    from gmcpt.regress.run import check_suite
    from gmcpt.regress.manifest import load_suite

    mi.set_log_level(mi.LogLevel.Error)
    with tempfile.TemporaryDirectory() as temporary:
        base = Path(temporary)
        suite = base / "repo" / "scenes"
        shutil.copytree(ROOT / "scenes", suite)
        (base / "shared").symlink_to(ROOT.parent / "shared")  # the breakfast room's ../../shared
        scene = suite / "cornell-box" / "scene.xml"
        scene.write_text(scene.read_text().replace(RED, GREEN))
        results = check_suite(load_suite(suite))
        report = write_html(base / "report.html", results, title="gmcpt regress scenes")
        OUT.parent.mkdir(parents=True, exist_ok=True)
        browser = shutil.which("chromium-headless-shell") or shutil.which("chromium")
        if browser:
            subprocess.run([browser, "--headless", "--no-sandbox", "--hide-scrollbars", "--window-size=900,760",
                            f"--screenshot={OUT}", report.as_uri()], check=True, capture_output=True, timeout=120)
            print(f"wrote {OUT} (screenshot of the report)")
        else:
            imsave(OUT, composite(report_order(results)[0]))
            print(f"wrote {OUT} (no headless browser: golden, check and FLIP map of the first failed scene)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
