"""What a frame's parts cost on a machine: the explicit model a budget's chooser weighs time with.

A frame's choice (:mod:`gmcpt.sampling.budget`, :mod:`gmcpt.sampling.strategies`) is a function of its arguments, what
the frame itself reads (its probe's noise, its guides' edges) and a :class:`CostModel`, never of timings taken while a
process renders: timings differ between machines, runs and the frames before, so an image chosen from them could not be
made again. The same arguments and the same model give the same image, on any machine, after any frames.

The model is per machine, not per scene: a scene's pace could enter only as a reading of the frame itself, and the
frame's own timings are no more repeatable than a process's. By default it is measured once on a machine
(:func:`measure_costs`, Mitsuba's own Cornell box) and stored under the cache folder (:func:`machine_costs`);
``gmcpt render --costs FILE`` gives another, such as the one a render's JSON sidecar recorded (:func:`read_costs`
reads a costs file and a sidecar alike). A time budget (``--time``) spends wall time and sizes its passes by their
measured pace; the model only gives its first estimate of OIDN's seconds.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import platform
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Callable

from ..errors import GmcptError
from ..io.files import cache_folder, json_text

#: What a costs file says it is; a sidecar is read by its ``costs`` entry alone.
COSTS_FORMAT = "gmcpt-costs 1"
#: The side of the square frame the model is measured at: the evaluation's size, where a pass's launch is a small
#: part of its pixels' work.
MEASURE_SIDE = 256
#: Timed rounds of every part, after one untimed round that compiles and loads them; the fastest of each counts.
MEASURE_RUNS = 5
#: Samples a pixel of the timed path tracing, and primary rays a pixel of the timed guide pass (a budget of 4's).
MEASURE_SPP = 4


@dataclass(frozen=True)
class CostModel:
    """Seconds of a frame's parts on one machine, per pixel (and per sample or ray where they grow with them).

    Attributes
    ----------
    path : one path sample of one pixel (Mitsuba's render of every pixel).
    guide_ray : one primary ray of one pixel in the guide pass (albedo, normal, depth; no shadow ray).
    sparse_extra : what the sparse way adds to a dense frame a pixel: the feature pass's shadow rays and the rays the
        guides lack, the placement of the samples, the generator.
    denoise : OIDN's usual model, a pixel.
    denoise_large : OIDN's large model (guides taken as clean), a pixel.
    """

    path: float
    guide_ray: float
    sparse_extra: float
    denoise: float
    denoise_large: float

    def __post_init__(self):
        for name, value in self.record().items():
            if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value) \
                    or value <= 0:
                raise GmcptError(f"the cost model's {name} must be a positive number of seconds, got {value!r}")

    def record(self) -> dict:
        """The model as a sidecar and a costs file hold it (``costs``)."""
        return asdict(self)

    def completion_seconds(self, pixels: int, large: bool = False) -> float:
        """OIDN's seconds on ``pixels`` pixels: its usual model, or with ``large`` its large one."""
        return pixels * (self.denoise_large if large else self.denoise)

    def dense_seconds(self, pixels: int, budget: float, guide_rays: int) -> float:
        """A dense frame's seconds: ``budget`` samples and ``guide_rays`` guide rays a pixel, then OIDN."""
        return pixels * (budget * self.path + guide_rays * self.guide_ray + self.denoise)

    def large_model_seconds(self, pixels: int, guide_rays: int, clean_rays: int) -> float:
        """What OIDN's large model adds to a dense frame whose guides have ``guide_rays`` rays: its time over the
        usual model's, and the guide rays up to ``clean_rays``."""
        return pixels * (self.denoise_large - self.denoise + max(clean_rays - guide_rays, 0) * self.guide_ray)


def read_costs(path: str | os.PathLike, name: str = "--costs") -> CostModel:
    """The :class:`CostModel` in ``path``: a costs file (:func:`machine_costs` writes them) or a render's JSON
    sidecar, whose ``costs`` entry is the model that render used. A one-line :class:`GmcptError` naming ``name``
    where the file holds none."""
    try:
        return _model(json.loads(Path(path).read_text()))
    except (OSError, ValueError, GmcptError) as error:
        raise GmcptError(f"{name} {path}: {_reason(error)}") from None


def _model(data) -> CostModel:
    """The model in a costs file's or a sidecar's parsed JSON, else a :class:`GmcptError` saying why not."""
    costs = data.get("costs") if isinstance(data, dict) else None
    if not isinstance(costs, dict):
        raise GmcptError("no cost model in it (a 'costs' entry, as a render's JSON has with --budget or --time)")
    names = [field.name for field in fields(CostModel)]
    if set(costs) != set(names):
        given = ", ".join(sorted(costs)) or "none"
        raise GmcptError(f"its cost model needs exactly {', '.join(names)}; it has {given}")
    return CostModel(**costs)


def _reason(error: BaseException) -> str:
    if isinstance(error, json.JSONDecodeError):
        return f"not JSON ({error.msg}, line {error.lineno})"
    return getattr(error, "strerror", None) or " ".join(str(error).split())


def machine() -> str:
    """This machine as its model's file names it: the Mitsuba variant, the CPU's model and the threads there are."""
    import mitsuba as mi

    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        with open("/proc/cpuinfo") as cpuinfo:
            cpu = next((line.split(":", 1)[1].strip() for line in cpuinfo if line.startswith("model name")), cpu)
    threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return f"{mi.variant()}, {cpu}, {threads} threads"


def machine_costs_path() -> Path:
    """Where this machine's measured model is stored: one file a machine (:func:`machine`), so that a cache
    folder shared by several machines keeps each one's."""
    return cache_folder("costs") / f"{hashlib.sha256(machine().encode()).hexdigest()[:16]}.json"


def machine_costs(say: Callable[[str], None] = lambda message: None) -> CostModel:
    """This machine's :class:`CostModel`: the stored one, else measured now (:func:`measure_costs`) and stored. A
    stored file that holds no model is measured again, with a one-line note on stderr."""
    path = machine_costs_path()
    try:
        return _model(json.loads(path.read_text()))
    except FileNotFoundError:
        pass
    except (OSError, ValueError, GmcptError) as error:
        print(f"note: {path}: {_reason(error)}; measuring this machine's cost model again", file=sys.stderr)
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
    say(f"measuring this machine's cost model, once (stored in {path})")
    start = time.perf_counter()
    model = measure_costs()
    _store(path, json_text({"format": COSTS_FORMAT, "costs": model.record(), "machine": machine(),
                            "measured": {"seconds": round(time.perf_counter() - start, 1),
                                         "on": f"Mitsuba's Cornell box at {MEASURE_SIDE}x{MEASURE_SIDE}",
                                         "date": time.strftime("%Y-%m-%d")}}))
    try:  # another process may have stored its measurement first: every process then weighs with that one
        return _model(json.loads(path.read_text()))
    except (OSError, ValueError, GmcptError):
        return model


def _store(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` unless a file is there already, whole or not at all (a temporary beside it, linked
    into place): a process reading the model never sees half of one, and two processes that measured at once both
    weigh with the first one stored. A folder that cannot be written is a one-line note: the next process measures."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, staged = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".json", dir=path.parent)
    except OSError as error:
        print(f"note: cannot store the cost model in {path.parent}: {_reason(error)}", file=sys.stderr)
        return
    try:
        with os.fdopen(handle, "w") as file:
            file.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staged, 0o666 & ~umask)  # mkstemp makes 0600; a plain file's mode, as gmcpt.io.files gives
        with contextlib.suppress(FileExistsError):
            os.link(staged, path)
    finally:
        os.unlink(staged)


def measure_costs(side: int = MEASURE_SIDE) -> CostModel:
    """Time a frame's parts on Mitsuba's own Cornell box at ``side`` x ``side`` (box filter, as the bundled scenes):
    path tracing at :data:`MEASURE_SPP`, a guide pass of as many rays, the feature pass a sparse frame adds, its
    placement and the default completion's generator, and OIDN's two models (:func:`_fastest`)."""
    import mitsuba as mi
    import numpy as np

    from ..completion import DEFAULT_METHOD, complete
    from ..image.denoise import CLEAN_GUIDE_RAYS, denoise_oidn
    from ..frame import DEFAULT_FEATURE_SPP, SparseFrame
    from .masks import DEFAULT_RATE, make_mask
    from ..render.kernels import feature_means, render_native

    description = mi.cornell_box()
    description["sensor"]["film"].update(width=side, height=side, rfilter={"type": "box"})
    scene = mi.load_dict(description)
    sensor, integrator, pixels = scene.sensors()[0], scene.integrator(), side * side
    image = render_native(scene, sensor, integrator, MEASURE_SPP, 0, any_size=True).reshape(side, side, 3)
    features = feature_means(scene, sensor, DEFAULT_FEATURE_SPP, 0).buffers()
    mask = make_mask(side, side, DEFAULT_RATE, "random", 0)
    frame = SparseFrame(radiance=np.where(mask[..., None], image, 0).astype(np.float32), mask=mask,
                        variance=np.zeros(mask.shape, np.float32), spp=16, **features)
    albedo, normal = features["albedo"], features["normal"]
    seconds = _fastest({
        "path": lambda: render_native(scene, sensor, integrator, MEASURE_SPP, 0, any_size=True),
        "guide": lambda: feature_means(scene, sensor, MEASURE_SPP, 0, visibility=False),
        "top_up": lambda: feature_means(scene, sensor, DEFAULT_FEATURE_SPP - MEASURE_SPP, 0),
        "placement": lambda: _place(frame),
        "denoise": lambda: denoise_oidn(image, albedo, normal, MEASURE_SPP),
        "large": lambda: denoise_oidn(image, albedo, normal, CLEAN_GUIDE_RAYS)},
        generator=lambda: complete(frame, DEFAULT_METHOD).timings.get("pre_completion_s", 0.0))
    extra = seconds["top_up"] + seconds["placement"] + seconds["generator"]
    return CostModel(path=seconds["path"] / (MEASURE_SPP * pixels), guide_ray=seconds["guide"] / (MEASURE_SPP * pixels),
                     sparse_extra=extra / pixels, denoise=seconds["denoise"] / pixels,
                     denoise_large=seconds["large"] / pixels)


def _place(frame) -> None:
    """Place a sparse frame's two passes as :mod:`gmcpt.sampling.strategies` does: by the feature edges, then by where
    the first pass's samples disagree (timed, not used)."""
    import numpy as np

    from .masks import mask_rng, sample_by_density, second_pass_mask
    from .placement import error_density, feature_density, first_pass_count

    density = feature_density(frame.albedo, frame.normal, frame.depth, frame.visibility, frame.coverage)
    count = int(frame.mask.sum())
    first = sample_by_density(density, first_pass_count(count), mask_rng(0))
    errors = error_density(np.where(first[..., None], frame.radiance, 0), frame.variance, first, frame.albedo,
                           frame.coverage, density)
    second_pass_mask(errors, count - int(first.sum()), first, 0)


def _fastest(works: dict, **reporting) -> dict:
    """The fewest seconds of each of ``works`` (name -> a call) over :data:`MEASURE_RUNS` rounds, after one untimed
    round that compiles and loads; each of ``reporting`` (name -> a call) returns its own seconds (a completion's
    generator, without its other stages). Every round runs every part, so that a load that comes and goes on the
    machine weighs on all of them alike: the chooser reads their ratios."""
    calls = {**works, **reporting}
    for call in calls.values():
        call()
    seconds = {name: math.inf for name in calls}
    for _ in range(MEASURE_RUNS):
        for name, call in calls.items():
            start = time.perf_counter()
            result = call()
            took = float(result) if name in reporting else time.perf_counter() - start
            seconds[name] = min(seconds[name], took)
    return seconds
