"""Training examples from real scene files: random views of imported public scenes.

    gmcpt dataset --real data/train-scenes --out data/real-train --train 40 --val 4

The procedural scenes (:mod:`gmcpt.dataset.scenes`) lack what real interiors have (many small
objects, textures, light arriving indirectly); this source adds examples rendered from scene files
such as ``scripts/import_scenes.py`` writes for the training-only scenes (``FOLDER/scene.xml`` and
``FOLDER/rand_sceneN.xml``, the same room from other cameras). Per seed, drawn from its own generator:

1. a scene file, uniformly among the sorted files of ``DatasetSpec.real_files``;
2. a view: the file's camera turned by a yaw in +-``YAW`` and a pitch in +-``PITCH`` degrees about its
   own axes, its film ``side`` x ``side`` pixels with ``side`` in [1, ``ZOOM``] x the example's size and a
   crop of the example's size at a random offset (a zoomed-in part of the view: the 128-pixel examples
   then see detail at the scale a 256-pixel evaluation frame does);
3. the frames exactly as :func:`gmcpt.dataset.build.render_example` renders procedural ones;
4. a light scale: every radiance array is multiplied by ``target / p95``, where p95 is the 95th
   luminance percentile of the reference and ``target`` is drawn from the spec's ``exposure_range``, so
   the brightness varies as the procedural set's does (radiance is linear in the emitters, so this is
   what scaling the emitters would render, without a preview render).

The scenes used by the evaluation (:mod:`gmcpt.evaluation.scenes`) and the held-out ``classroom`` and
``staircase`` are refused, so nothing the evaluation measures is trained on.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import GmcptError

#: folders never used for anything (as scripts/import_scenes.py's HELD_OUT)
HELD_OUT = ("classroom", "staircase")
YAW, PITCH, ZOOM = 12.0, 6.0, 2.0
#: a view's random draws; distinct from the build's other per-seed generators
VIEW_STREAM = 0x5CE4E


def real_scene_files(root: str | Path, refused: frozenset[str] = frozenset()) -> tuple[str, ...]:
    """The sorted scene files under ``root`` (``FOLDER/scene.xml``, ``FOLDER/rand_sceneN.xml``), relative to it.

    Raises :class:`~gmcpt.errors.GmcptError` for a missing folder, no scene file, or a held-out scene or one
    of ``refused`` (folder names: the evaluation's scenes, which the dataset CLI passes) among them.
    """
    root = Path(root)
    if not root.is_dir():
        raise GmcptError(f"real scene folder not found: {root}")
    folders = sorted(path for path in root.iterdir() if path.is_dir() and (path / "scene.xml").is_file())
    refused = [f.name for f in folders if f.name in HELD_OUT or f.name in refused]
    if refused:
        raise GmcptError(f"{root} holds {', '.join(refused)}: held-out and evaluation scenes are never trained on")
    files = [path.relative_to(root).as_posix() for folder in folders
             for path in [folder / "scene.xml", *sorted(folder.glob("rand_scene*.xml"))]]
    if not files:
        raise GmcptError(f"no scene files in {root} (expected FOLDER/scene.xml, as scripts/import_scenes.py writes)")
    return tuple(files)


@dataclass(frozen=True)
class View:
    """One example's scene file and camera (step 2 of the module docstring)."""

    file: str
    yaw: float
    pitch: float
    side: int
    offset: tuple[int, int]
    target: float

    def edit(self, resolution: int):
        """The change to the parsed scene (:func:`gmcpt.render.scene.load_scene`'s ``edit``) that sets this view."""
        def apply(root: ET.Element) -> None:
            sensor = root.find("./sensor")
            transform = sensor.find("transform[@name='to_world']")
            if transform is None:
                transform = ET.SubElement(sensor, "transform", name="to_world")
            # first in the list is applied first: turns about the camera's own axes, before its placement
            transform.insert(0, ET.Element("rotate", x="1", angle=f"{self.pitch:.6g}"))
            transform.insert(0, ET.Element("rotate", y="1", angle=f"{self.yaw:.6g}"))
            film = sensor.find("film")
            for name, value in (("crop_offset_x", self.offset[0]), ("crop_offset_y", self.offset[1]),
                                ("crop_width", resolution), ("crop_height", resolution)):
                node = film.find(f"integer[@name='{name}']")
                if node is None:
                    node = ET.SubElement(film, "integer", name=name)
                node.set("value", str(value))
        return apply


def draw_view(seed: int, files: tuple[str, ...], resolution: int, exposure_range: tuple[float, float]) -> View:
    """The view of example ``seed``: a pure function of its arguments."""
    rng = np.random.default_rng([seed, VIEW_STREAM])
    file = files[int(rng.integers(len(files)))]
    yaw, pitch = (float(rng.uniform(-limit, limit)) for limit in (YAW, PITCH))
    side = int(rng.integers(resolution, int(resolution * ZOOM) + 1))
    offset = (int(rng.integers(side - resolution + 1)), int(rng.integers(side - resolution + 1)))
    return View(file, yaw, pitch, side, offset, float(rng.uniform(*exposure_range)))
