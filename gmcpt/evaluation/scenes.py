"""The scenes the benchmarks and the evaluation run on.

Two bundled scenes, held-out procedural scenes (:class:`ProceduralScene`: seeds
of the dataset's test split, never trained on), and ``../shared/scenes/breakfast-room`` (CC-BY, read in
place, never copied) where present, in two forms:

- ``breakfast-room-open``: the scene with its two window panes left out
  (``windowglass1``, ``windowglass2``), which is what the quality tables use.
  As shipped, the room's main light is a small, very bright sphere ("fakesun")
  seen only through dielectric glass, so every sunlit pixel is a caustic that
  a path tracer reaches only by chance: two independent 512-spp renders at
  128x128 agree to 12.4 dB PSNR, so no affordable reference exists and every
  method scores ~11 dB. With the panes out the sun is sampled directly and
  two 512-spp renders agree to 31.5 dB (measured with Mitsuba 3.9.1).
- ``breakfast-room``: as shipped, for timings (``benchmarks/render_cost.py``)
  and to show the reference-noise problem above.

Real interiors imported from Mitsuba 0.6 by ``scripts/import_scenes.py`` into the ignored ``data/real-scenes``
(``$GMCPT_REAL_SCENES`` overrides): too large to commit, so each is skipped with one line where it was not
imported. With the breakfast room they make the *real* scenes of the evaluation's separate means; the bundled
and procedural ones are the *synthetic* scenes.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import BadValue
from ..seeds import REFERENCE_FIRST_SEED

ROOT = Path(__file__).resolve().parents[2]
#: the shared scenes beside the checkout (``$GMCPT_SHARED_SCENES`` overrides); a fresh clone has none,
#: and every use of them skips the scenes that are not there
SHARED_SCENES = Path(os.environ.get("GMCPT_SHARED_SCENES") or ROOT.parent / "shared" / "scenes")
#: the scenes ``scripts/import_scenes.py`` writes
IMPORTED_SCENES = Path(os.environ.get("GMCPT_REAL_SCENES") or ROOT / "data" / "real-scenes")


@dataclass(frozen=True)
class EvalScene:
    """A scene file plus the ids of elements left out when loading it."""

    name: str
    path: Path
    without: tuple[str, ...] = ()
    real: bool = False  # a real interior (else a bundled test scene)
    how_to_get: str = ""  # said when the scene is missing
    credit: str = ""  # author and licence of a scene made by others

    def available(self) -> bool:
        return self.path.is_file()

    def missing_line(self) -> str:
        return f"skipping {self.name}: {self.path} not found" + (f" ({self.how_to_get})" if self.how_to_get else "")

    def load(self, resolution: int | tuple[int, int]):
        """The scene at a square side or (W, H)."""
        from ..render.scene import load_scene
        from .reference import film_size

        return load_scene(self.path, film_size(resolution), without=self.without)

    def reference(self, resolution: int = 256, spp: int = 4096, **options):
        """The cached reference (:func:`gmcpt.evaluation.reference.render_reference`; ``options``: seed, progress, ...)."""
        from .reference import render_reference

        return render_reference(self.path, resolution, spp, without=self.without, **options)


@dataclass(frozen=True)
class ProceduralScene:
    """Procedural scene ``seed`` (:mod:`gmcpt.dataset.scenes`), exposed as the dataset exposes it.

    The exposure is the dataset's (a 16-spp preview at the evaluation
    resolution, :func:`gmcpt.dataset.build.pick_exposure`); references are
    cached like those of scene files, keyed by the seed, the exposure and the
    generator's source, so a changed generator renders new ones.
    """

    seed: int
    real = False
    credit = ""  # the project's own

    @property
    def name(self) -> str:
        return f"proc-{self.seed}"

    def available(self) -> bool:
        return True

    def exposure(self, resolution: int) -> float:
        from ..dataset.build import DatasetSpec, pick_exposure

        return pick_exposure(self.seed, resolution, DatasetSpec())

    def load(self, resolution: int, spp: int = 16):
        from ..dataset.scenes import build_scene

        return build_scene(self.seed, resolution, self.exposure(resolution), spp)

    def reference(self, resolution: int = 256, spp: int = 4096, seed: int = REFERENCE_FIRST_SEED, pass_spp: int = 256,
                  progress=None):
        from .reference import cached_reference

        exposure = self.exposure(resolution)
        # the scene is a function of the seed, the exposure and the generator's source alone; the
        # leading 1 keeps the keys of references made when it was the dataset version
        digest = hashlib.sha256(json.dumps([1, self.seed, exposure]).encode())
        for module in ("scenes.py", "meshes.py", "textures.py"):
            digest.update((Path(__file__).parents[1] / "dataset" / module).read_bytes())
        key = f"{self.name}-{resolution}px-{spp}spp-s{seed}-{digest.hexdigest()[:12]}"
        return cached_reference(key, lambda: self.load(resolution), spp, seed, pass_spp, progress, self.name)


def procedural_scenes(count: int) -> list[ProceduralScene]:
    """The first ``count`` held-out (test split) procedural scenes."""
    from ..dataset import SPLIT_SEED_BASE

    return [ProceduralScene(SPLIT_SEED_BASE["test"] + index) for index in range(count)]


CORNELL = EvalScene("cornell-box", ROOT / "scenes" / "cornell-box" / "scene.xml")
STILL_LIFE = EvalScene("still-life", ROOT / "scenes" / "still-life" / "scene.xml")
WIG42 = "by Wig42 (CC BY 3.0), Mitsuba port by Benedikt Bitterli"
BREAKFAST = EvalScene("breakfast-room", SHARED_SCENES / "breakfast-room" / "scene.xml", real=True,
                      credit=f"The Breakfast Room {WIG42}")
BREAKFAST_OPEN = EvalScene("breakfast-room-open", BREAKFAST.path, ("windowglass1", "windowglass2"), real=True,
                           credit=BREAKFAST.credit)
#: public real interiors (Bitterli's Rendering Resources, Mitsuba 0.6 ports in hchoi405/dppm-scenes), as
#: scripts/import_scenes.py names them; its READMEs beside each imported scene say more
IMPORTED = tuple(EvalScene(name, IMPORTED_SCENES / name / "scene.xml", real=True, credit=credit,
                           how_to_get="python scripts/import_scenes.py imports it")
                 for name, credit in (
                     ("dining-room", f"The Breakfast Room {WIG42}, lit by its sun and sky"),
                     ("living-room", f"The Grey & White Room {WIG42}"),
                     ("sponza", "Sponza Atrium by Marko Dabrovic (the source states no licence)"),
                     ("veach-lamp", "after Eric Veach's lamp test scene, Mitsuba 0.6's `bidir` example "
                                    "(the source states no licence)")))

#: scenes of the quality tables
QUALITY_SCENES = (CORNELL, STILL_LIFE, BREAKFAST_OPEN, *IMPORTED)
ALL_SCENES = (*QUALITY_SCENES, BREAKFAST)


def by_name(names: list[str] | None, default=QUALITY_SCENES) -> list[EvalScene]:
    """Scenes named in ``names`` (default: ``default``); raises :class:`~gmcpt.errors.BadValue` for an unknown name."""
    if not names:
        return list(default)
    known = {scene.name: scene for scene in ALL_SCENES}
    unknown = [name for name in names if name not in known]
    if unknown:
        raise BadValue(f"unknown scene {', '.join(unknown)}; choose from {', '.join(known)}")
    return [known[name] for name in names]


def evaluation_scenes(names: list[str] | None = None, procedural: int = 2, say=None) -> list:
    """The available scenes among ``names`` (default: the quality scenes) and ``procedural`` held-out procedural
    ones; ``say`` gets one line for each named scene that is missing."""
    chosen = by_name(names)
    for scene in chosen:
        if not scene.available() and say is not None:
            say(scene.missing_line())
    return [scene for scene in chosen if scene.available()] + procedural_scenes(procedural)


def evaluation_folder_names() -> frozenset[str]:
    """Folder and scene names of the scenes the evaluation measures: never trained on (:mod:`gmcpt.dataset.real`)."""
    folders = {scene.path.parent.name for scene in ALL_SCENES if scene.real}
    return frozenset(folders | {scene.name for scene in ALL_SCENES})
