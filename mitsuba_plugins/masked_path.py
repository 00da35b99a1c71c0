"""The ``masked_path`` integrator: sparse path tracing + completion in one call."""
from __future__ import annotations

import mitsuba as mi

from gmcpt.completion import DEFAULT_METHOD, check_options
from gmcpt.completion.tiles import DEFAULT_TILE, check_tile
from gmcpt.sampling.costs import read_costs
from gmcpt.errors import GmcptError
from gmcpt.io.exr import channel_names, pack
from gmcpt.io.film import fill_film
from gmcpt.limits import check_feature_spp, check_seed
from gmcpt.sampling.masks import DEFAULT_PATTERN, DEFAULT_RATE, check_pattern, check_rate
from gmcpt.pipeline import Rendered, render_and_complete
from gmcpt.runtime.plugins import constructor
from gmcpt.render.kernels import DEFAULT_FEATURE_SPP
from gmcpt.sampling.strategies import RenderSettings, check_one_sample_count
from gmcpt.render.scene import DEFAULT_PATH, scene_sensor, settle_normals
from gmcpt.temporal.sequence import RenderLoop


class MaskedPathIntegrator(mi.SamplingIntegrator):
    r"""
    .. _integrator-masked_path:

    Masked path tracer (:monosp:`masked_path`)
    ------------------------------------------

    .. pluginparameters::

     * - rate
       - |float|
       - Fraction of pixels that are path traced, in (0, 1], each at the sampler's spp. (Default: 0.3 when
         an spp is given to ``mi.render`` or the mask is not ``two_pass``; else a budget, below)
     * - budget
       - |float|
       - Mean path samples a pixel, instead of ``rate`` and the sampler's spp: the first pass of ``two_pass``
         chooses per frame between tracing ``budget / 16`` of the pixels at 16 spp (completed by the
         ``completion`` method) and tracing every pixel (see ``gmcpt.sampling.budget``); 0: none. (Default: with
         neither ``rate`` nor ``budget`` set, 0.3 x the sampler's spp: as many samples as rate 0.3 traces)
     * - time
       - |float|
       - Seconds of wall time for the frame and its completion, instead of ``rate``, ``budget`` and the
         sampler's spp: guides, then Mitsuba's own render of every pixel in passes sized by the pace of the
         passes before, OIDN's time kept back; 0: none. (Default: 0)
     * - costs
       - |string|
       - A JSON file holding the cost model a budget's choice weighs time with (a render's JSON sidecar holds the
         one it used): the same settings and model give the same image on any machine; relative to the working
         folder. (Default: this machine's, measured once and stored, see ``gmcpt.sampling.costs``)
     * - mask
       - |string|
       - Sample placement: ``two_pass`` (half the budget where the feature buffers have edges, the rest
         where the first half's samples disagree), ``adaptive`` (all by the features), or the even
         patterns ``random`` (the paper's), ``stratified``, ``blue_noise``. (Default: ``two_pass``)
     * - seed
       - |int|
       - Seed of the mask and of the samplers; added to the seed given to ``mi.render``. (Default: 0)
     * - max_depth
       - |int|
       - Longest path of the default nested ``path`` integrator (-1: unbounded). (Default: 8)
     * - rr_depth
       - |int|
       - Depth at which Russian roulette starts, for the default nested ``path``. (Default: 5)
     * - feature_spp
       - |int|
       - Primary samples per pixel of the feature pass (albedo, normal, depth, visibility). (Default: 16)
     * - completion
       - |string|
       - Reconstruction method run after rendering: see ``gmcpt.methods()``. (Default: ``gan_oidn``: GAN fill, then Intel OIDN)
     * - weights
       - |string|
       - Generator weights of the GAN methods: a shipped name or a ``.pt`` path, checked at load time.
         (Default: the shipped ``gan-cpu``)
     * - history
       - |int|
       - Past frames a frame reuses (0: none). Above 0, successive ``mi.render`` calls on the same scene are the
         frames of one sequence (move the camera and shapes through ``mi.traverse`` between them; set a moved
         mesh's ``vertex_normals`` with its vertices, or Mitsuba sums new ones, other bits each run): each frame
         spends ``budget`` (or ``time``) on every pixel, reuses the samples of up to ``history`` frames before
         it where they still hold, then OIDN (see ``gmcpt.temporal.sequence``); ``mi.render``'s ``seed``, when given,
         is the frame's number. Another scene, another film size or ``reset()`` starts over. ``rate``,
         ``mask``, ``completion``, ``weights`` and ``costs`` are single-frame options, refused here. (Default: 0)
     * - tile
       - |int|
       - Largest side of the tiles a larger frame is completed in (overlapping, blended), so memory stays
         bounded at any resolution; 0 completes the whole frame at once. (Default: 1024)
     * - (Nested plugin)
       - :paramtype:`integrator`
       - The integrator that computes radiance along each traced ray. (Default: ``path``)

    Only the pixels the mask selects are traced, from a compacted pixel list
    (``round(rate * W * H) * spp`` lanes), with the scene's spp per traced
    pixel and a box estimate per pixel; feature buffers are computed for every
    pixel in the same call. The completion method then fills the rest. With a
    budget (the default), each frame's first pass chooses that or tracing every
    pixel, the same samples in all.

    ``mi.render`` returns an ``(H, W, 17)`` tensor: the completed RGB first,
    then the layers named by :meth:`aov_names` (sparse RGB, mask, albedo,
    normal, depth, visibility, variance, coverage); ``gmcpt.io.exr.unpack`` reads
    it. The sensor's film holds the same channels, named, as Mitsuba's own
    integrators leave theirs (see :mod:`gmcpt.io.film`)::

        image = mi.render(scene)
        mi.util.write_bitmap("x.exr", scene.sensors()[0].film().bitmap())

    .. code-block:: xml

        <integrator type="masked_path">
            <float name="rate" value="0.3"/>
            <string name="completion" value="interp"/>
            <integrator type="path">
                <integer name="max_depth" value="8"/>
            </integrator>
        </integrator>
    """

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        # no rate and no budget: the default budget, DEFAULT_RATE x the sensor's spp (settings)
        self.rate = check_rate(props["rate"]) if "rate" in props else None
        self.budget = float(props.get("budget", 0.0))
        self.time = float(props.get("time", 0.0))  # 0: none; checked by self.settings() below
        self.mask_pattern = check_pattern(props.get("mask", DEFAULT_PATTERN))
        self.seed = check_seed(props.get("seed", 0))
        self.feature_spp = check_feature_spp(props.get("feature_spp", DEFAULT_FEATURE_SPP))
        self.completion = props.get("completion", DEFAULT_METHOD)
        self.weights = props.get("weights", "") or None
        self.tile = check_tile(props.get("tile", DEFAULT_TILE))
        self.costs = props.get("costs", "") or None
        self.cost_model = read_costs(self.costs, "costs") if self.costs else None  # a bad file fails at load time
        check_options(self.completion, self.weights)  # fail at load time on an unknown name, a bad weights file
        self.settings()  # and on a bad budget or time, or a budget beside a mask other than two_pass (RenderSettings)
        nested = [props[name] for name in props.keys() if isinstance(props[name], mi.Integrator)]
        if len(nested) > 1:
            raise GmcptError("masked_path takes at most one nested integrator")
        depth_settings = {key: int(props.get(key)) for key in ("max_depth", "rr_depth") if key in props}
        if nested and depth_settings:
            raise GmcptError("set max_depth/rr_depth on the nested integrator, not on masked_path")
        if nested and not isinstance(nested[0], mi.SamplingIntegrator):
            raise GmcptError(f"the nested integrator must be a sampling integrator, got {nested[0].class_name()}")
        self.integrator = nested[0] if nested else mi.load_dict({**DEFAULT_PATH, **depth_settings})
        self.last_frame = None
        self.last_timings = {}
        self.history = int(props.get("history", 0))
        self.loop = None
        if self.history:
            given = [name for name in ("rate", "mask", "completion", "weights", "costs") if name in props]
            if given:
                raise GmcptError(f"masked_path with history spends its budget on every pixel, then OIDN: drop "
                                 f"{', '.join(given)}")
            self.loop = RenderLoop(self.budget or None, self.seed, self.history, self.time)

    def plugin_properties(self) -> dict:
        """The plugin's own properties as set (``rate``, ``mask``, ...), for a copy with some changed: a
        single frame's (``gmcpt render``), so ``history`` does not follow."""
        return {"rate": self.rate, "budget": self.budget, "time": self.time or None, "mask": self.mask_pattern,
                "seed": self.seed,
                "feature_spp": self.feature_spp,
                "completion": self.completion, "weights": self.weights, "tile": self.tile, "costs": self.costs}

    def completion_options(self) -> dict:
        """Keyword options for :func:`gmcpt.completion.complete` beside the method name."""
        return {"tile": self.tile, **({} if self.weights is None else {"weights": self.weights})}

    def settings(self, seed: int = 0, spp: int = 0, sensor: mi.Sensor | None = None) -> RenderSettings:
        """What :func:`render_sparse_frame` traces; ``spp`` (0: the sensor's) is refused beside a budget.

        With neither ``rate`` nor ``budget`` set, no ``spp`` and the ``two_pass`` mask, the budget is
        ``DEFAULT_RATE`` x ``sensor``'s spp (the samples rate ``DEFAULT_RATE`` would trace), at least 1;
        otherwise (and without a ``sensor``) the rate is ``DEFAULT_RATE``."""
        check_one_sample_count({"spp": "an spp to mi.render"}, spp=spp, budget=self.budget, time=self.time)
        budget = self.budget
        if not budget and not self.time and self.rate is None and not spp and sensor is not None \
                and self.mask_pattern == "two_pass":
            budget = max(1.0, DEFAULT_RATE * sensor.sampler().sample_count())
        return RenderSettings(rate=DEFAULT_RATE if self.rate is None else self.rate, pattern=self.mask_pattern,
                              seed=self.seed + int(seed), spp=int(spp), feature_spp=self.feature_spp, budget=budget,
                              time=self.time, costs=self.cost_model)

    def render_frame(self, scene: mi.Scene, sensor: mi.Sensor | None = None, seed: int = 0, spp: int = 0,
                     progress=None, check=None) -> Rendered:
        """Render and complete one frame (:func:`gmcpt.pipeline.render_and_complete`) with this plugin's settings;
        the front door of ``mi.render``, the ``render`` command and the regression suite."""
        sensor = sensor if sensor is not None else scene_sensor(scene)
        rendered = render_and_complete(scene, self.integrator, self.settings(seed, spp, sensor), self.completion,
                                       self.completion_options(), sensor, progress, check)
        self.last_frame, self.last_timings = rendered.frame, rendered.timings
        return rendered

    def render(self, scene: mi.Scene, sensor: int | mi.Sensor = 0, seed: int = 0, spp: int = 0,
               develop: bool = True, evaluate: bool = True) -> mi.TensorXf:
        if not develop:
            raise GmcptError("masked_path only renders developed images (develop=True)")
        if isinstance(sensor, int):
            sensor = scene_sensor(scene, sensor)
        settle_normals(scene)  # a scene loaded by mi.load_file: its computed normals, the same bits every load
        if self.loop is not None:
            if spp:
                raise GmcptError("masked_path with history spends its budget: give it a budget, not an spp")
            sequence_frame = self.loop.render(scene, sensor, self.integrator, int(seed) or None)
            self.last_frame, self.last_timings = sequence_frame.layers, sequence_frame.timings
            tensor = pack(sequence_frame.layers, sequence_frame.image)
        else:
            rendered = self.render_frame(scene, sensor, seed, spp)
            tensor = pack(rendered.frame, rendered.image)
        fill_film(sensor.film(), tensor)  # so that film().bitmap() and film().write() give the named layers
        return mi.TensorXf(tensor)

    def reset(self) -> None:
        """Start a new sequence: the next ``mi.render`` is frame 0 (with ``history``; nothing to do without)."""
        if self.loop is not None:
            self.loop.reset()

    def sample(self, scene, sampler, ray, medium=None, active=True):
        return self.integrator.sample(scene, sampler, ray, medium, active)

    def aov_names(self) -> list[str]:
        """Names of the channels after R, G, B, as ``mi.render``'s tensor and the film hold them."""
        return channel_names()[3:]

    def to_string(self) -> str:
        return (f"MaskedPathIntegrator[rate={self.rate}, budget={self.budget}, time={self.time}, "
                f"mask={self.mask_pattern!r}, seed={self.seed}, "
                f"feature_spp={self.feature_spp}, completion={self.completion!r}, weights={self.weights!r}, "
                f"costs={self.costs!r}, history={self.history},\n"
                f"  integrator={self.integrator}]")


def register() -> None:
    """Register ``masked_path`` with Mitsuba for the active variant."""
    mi.register_integrator("masked_path", constructor(MaskedPathIntegrator))

