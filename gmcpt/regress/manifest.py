"""A regression suite on disk: its scenes, its settings and its goldens.

A suite is a folder ``DIR`` of scene files: ``DIR/NAME.xml`` and
``DIR/NAME/scene.xml`` are the scene ``NAME``. Its goldens live in
``DIR/golden/``: one EXR per scene (``NAME.exr``, linear RGB) and
``manifest.json``::

    {"format": "gmcpt-regress 1",
     "settings": {"golden_spp": 1024, "rate": 0.5, "spp": 16, ...},
     "scenes": {"NAME": {"file": "NAME/scene.xml", "resolution": [64, 64],
                         "golden_render_s": 3.1, "thresholds": {"flip": 0.12, "block_psnr": 33.6},
                         "calibration": {"seeds": [1, 2, 3, 4, 5], "flip": [...], ...}}}}

A scene kept outside ``DIR`` is an entry whose ``file`` points there (relative
to ``DIR`` or absolute), with ``"optional": true`` if it may be absent (it is
then skipped, with the reason) and ``"without": [ids]`` for top-level elements
to leave out (:func:`gmcpt.render.scene.load_scene`); ``--update`` keeps such entries.
"""
from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from ..errors import GmcptError

FORMAT = "gmcpt-regress 1"
GOLDEN_FOLDER = "golden"
MANIFEST = "manifest.json"


@dataclass(frozen=True)
class Settings:
    """How goldens are rendered, how the cheap check renders, how thresholds are set.

    Attributes
    ----------
    golden_spp : samples per pixel of the golden (plain path tracing, full frame).
    rate, spp, method : the check: fraction of pixels traced, samples per traced pixel, completion method.
    resolution : (width, height) every scene is rendered at; None keeps each scene's film.
    seeds : how many seeds (1, 2, ... seeds) the check is calibrated on when the goldens are made.
    block : block side in pixels of the ``block_psnr`` metric.
    sigmas : a threshold lies this many standard deviations (over the calibration seeds) past the mean...
    flip_margin, psnr_margin_db : ...and at least this far: a fraction of the mean FLIP, decibels of block PSNR.
    """

    golden_spp: int = 1024
    rate: float = 0.5
    spp: int = 16
    method: str = "gan_pawnnm"
    resolution: tuple[int, int] | None = None
    seeds: int = 12
    block: int = 8
    sigmas: float = 5.0
    flip_margin: float = 0.2
    psnr_margin_db: float = 2.0

    def to_json(self) -> dict:
        data = asdict(self)
        data["resolution"] = list(self.resolution) if self.resolution else None
        return data

    @classmethod
    def from_json(cls, data: dict) -> "Settings":
        known = {f.name for f in fields(cls)}
        values = {key: value for key, value in data.items() if key in known}
        if values.get("resolution") is not None:
            values["resolution"] = tuple(int(v) for v in values["resolution"])
        return cls(**values)


@dataclass(frozen=True)
class SceneSpec:
    """A scene of the suite: its name, file (as the manifest writes it) and loading options."""

    name: str
    file: str
    without: tuple[str, ...] = ()
    optional: bool = False

    def path(self, folder: Path) -> Path:
        return (Path(folder) / self.file) if not Path(self.file).is_absolute() else Path(self.file)


@dataclass(frozen=True)
class Golden:
    """A scene's golden as the manifest records it (the image itself is ``golden/NAME.exr``)."""

    spec: SceneSpec
    resolution: tuple[int, int]
    render_s: float
    thresholds: dict
    calibration: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        return {**spec_json(self.spec), "resolution": list(self.resolution),
                "golden_render_s": round(self.render_s, 3), "thresholds": self.thresholds,
                "calibration": self.calibration}


def spec_json(spec: SceneSpec) -> dict:
    """A scene's manifest entry before it has a golden: its file and loading options."""
    entry = {"file": spec.file}
    if spec.without:
        entry["without"] = list(spec.without)
    if spec.optional:
        entry["optional"] = True
    return entry


@dataclass(frozen=True)
class Suite:
    """A suite folder, its settings and goldens (from the manifest) and its scenes.

    ``specs`` holds every scene, {name: SceneSpec}: those found in the folder, and those the manifest
    lists (kept as the manifest writes them); ``goldens`` {name: Golden} those with a golden.
    """

    folder: Path
    settings: Settings
    goldens: dict
    specs: dict

    @property
    def golden_folder(self) -> Path:
        return self.folder / GOLDEN_FOLDER

    def golden_path(self, name: str) -> Path:
        return self.golden_folder / f"{name}.exr"

    @property
    def manifest_path(self) -> Path:
        return self.golden_folder / MANIFEST

    def names(self) -> list[str]:
        """Every scene, sorted."""
        return sorted(self.specs)

    def spec(self, name: str) -> SceneSpec:
        return self.specs[name]

    def select(self, names: list[str] | None) -> list[str]:
        """``names`` checked against the suite (all scenes when empty); raises for an unknown name."""
        known = self.names()
        if not names:
            return known
        unknown = [name for name in names if name not in known]
        if unknown:
            raise GmcptError(f"no scene {', '.join(unknown)} in {self.folder} (scenes: {', '.join(known) or 'none'})")
        return list(dict.fromkeys(names))

    def skip_reason(self, name: str) -> str | None:
        """Why an optional scene is left out (its file is absent), else None."""
        spec = self.spec(name)
        path = spec.path(self.folder)
        if spec.optional and not path.is_file():
            return f"scene file not found: {path} (optional scene)"
        return None


def discover(folder: Path) -> dict:
    """The scenes in ``folder``: ``NAME.xml`` and ``NAME/scene.xml``, as {name: SceneSpec}."""
    found = {}
    for path in sorted(folder.glob("*.xml")):
        found[path.stem] = SceneSpec(path.stem, path.name)
    for path in sorted(folder.glob("*/scene.xml")):
        if path.parent.name != GOLDEN_FOLDER:
            found.setdefault(path.parent.name, SceneSpec(path.parent.name, f"{path.parent.name}/scene.xml"))
    return found


def load_suite(folder: str | Path) -> Suite:
    """Read the suite in ``folder`` (a manifest need not exist yet); raises one line on bad input."""
    folder = Path(folder)
    if not folder.is_dir():
        raise GmcptError(f"suite folder not found: {folder}")
    manifest = folder / GOLDEN_FOLDER / MANIFEST
    settings, goldens, specs = Settings(), {}, discover(folder)
    if manifest.is_file():
        try:
            data = json.loads(manifest.read_text())
            if data.get("format") != FORMAT:
                raise ValueError(f"format {data.get('format')!r}, expected {FORMAT!r}")
            settings = Settings.from_json(data["settings"])
            for name, entry in data["scenes"].items():
                spec = SceneSpec(name, entry["file"], tuple(entry.get("without", ())), bool(entry.get("optional")))
                specs[name] = spec
                if "thresholds" in entry:
                    goldens[name] = Golden(spec, tuple(entry["resolution"]), float(entry["golden_render_s"]),
                                           dict(entry["thresholds"]), dict(entry.get("calibration", {})))
        except (ValueError, KeyError, TypeError, AttributeError) as error:
            raise GmcptError(f"unreadable manifest {manifest}: {error}") from None
    return Suite(folder, settings, goldens, specs)


def manifest_json(settings: Settings, goldens: dict, specs: dict | None = None) -> str:
    """The manifest's text: ``goldens`` ({name: Golden}), and the ``specs`` ({name: SceneSpec}) without one."""
    entries = {name: spec_json(spec) for name, spec in (specs or {}).items()}
    entries.update({name: golden.to_json() for name, golden in goldens.items()})
    data = {"format": FORMAT, "settings": settings.to_json(),
            "scenes": {name: entries[name] for name in sorted(entries)}}
    text = json.dumps(data, indent=2)
    # lists of numbers on one line each
    return re.sub(r"\[([^\[\]{}\"]*)\]", lambda match: "[" + " ".join(match.group(1).split()) + "]", text) + "\n"


def with_settings(suite: Suite, **changes) -> Settings:
    """The suite's settings with ``changes`` (None values ignored) applied."""
    return replace(suite.settings, **{key: value for key, value in changes.items() if value is not None})
