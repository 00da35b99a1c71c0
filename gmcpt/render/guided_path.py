"""Mitsuba's ``path`` integrator that also returns OIDN's guides from its own first hits.

A dense frame's guides (albedo, normal) otherwise cost a pass of their own, as Mitsuba's ``aov`` integrator costs
a user: 4-10% of the path tracing at 4-16 samples a pixel (living room, Cornell box). Wrapping ``path`` in ``aov``
costs twice the two passes, since ``aov`` traces its own first intersection; this integrator reads the path's first
surface interaction instead. Its paths are ``path``'s for the same seed (the same sampler draws in the same order,
the same MIS and Russian roulette): its radiance is the same to the bit through the pixel-list kernel, and to the
last bit of a float through ``mi.render``'s film, which develops more channels (checked in the tests).

.. list-table::
   :header-rows: 1

   * - parameter
     - meaning
   * - ``max_depth``
     - longest path, in segments (-1: unbounded), as ``path``'s
   * - ``rr_depth``
     - depth from which Russian roulette may end a path, as ``path``'s
   * - ``light_samples``
     - emitter samples at the first hit (default 1: ``path``'s paths), stratified along the first coordinate (the one
       that picks the light, and the sun or the sky of a sunsky), weighed against the BSDF sample as that many
   * - ``features``
     - whether it returns the AOVs below (default true); without them every bounce is one loop's body, which a
       kernel traced anew (a moving shape's) traces once

With more light samples the first hit's direct light, which holds nearly all of a sunlit pixel's noise (one sample
picks the sun or the sky, a sun or another light, and is worth twice the sun or nothing), is a mean of several, at
the cost of their shadow rays alone (docs/experiments.md, sixty-third session).

AOVs, one value a sample: the first hit's :func:`first_hit_features` (albedo, normal, hit distance, hit, coverage),
the feature pass's planes (:func:`gmcpt.render.kernels.feature_means`), so both make the same guides.
"""
from __future__ import annotations

import re

import drjit as dr
import mitsuba as mi

from ..image.domain import ALBEDO_MIN
from .held import making_room, scene_state

#: The AOVs, in the order of :class:`gmcpt.render.kernels.FeatureMeans`'s planes.
FEATURE_PLANES = ("albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z", "distance", "hit",
                  "coverage")


def first_hit_features(si: mi.SurfaceInteraction3f, bsdf: mi.BSDFPtr) -> list:
    """The feature planes of a primary ray's hit ``si`` (:data:`FEATURE_PLANES`): the albedo is the diffuse
    reflectance of BSDFs with a diffuse lobe clipped to [0, 1], 0 for the others (Mitsuba's own gives a rough metal
    an "albedo" of 5 to 70 where its highlight faces the camera); all planes 0 on a miss."""
    hit = si.is_valid()
    diffuse = hit & mi.has_flag(bsdf.flags(), mi.BSDFFlags.DiffuseReflection)
    albedo = dr.select(diffuse, dr.clip(bsdf.eval_diffuse_reflectance(si, diffuse), 0.0, 1.0), 0.0)
    covered = dr.select(dr.max(albedo) >= ALBEDO_MIN, 1.0, 0.0)
    normal = dr.select(hit, si.sh_frame.n, 0.0)
    return [*albedo, *normal, dr.select(hit, si.t, 0.0), dr.select(hit, 1.0, 0.0), covered]


def _mis_weight(pdf_a: mi.Float, pdf_b: mi.Float) -> mi.Float:
    """The power heuristic, 0 where it is not finite (as ``path``'s)."""
    pdf_a = pdf_a * pdf_a
    weight = pdf_a / (pdf_a + pdf_b * pdf_b)
    return dr.detach(dr.select(dr.isfinite(weight), weight, 0.0))


class GuidedPath(mi.SamplingIntegrator):
    """``path`` with the first hit's feature planes as AOVs (module docstring)."""

    def __init__(self, props: mi.Properties):
        super().__init__(props)
        depth = props.get("max_depth", -1)
        self.max_depth = 0xFFFFFFFF if depth < 0 else depth
        self.rr_depth = props.get("rr_depth", 5)
        self.light_samples = props.get("light_samples", 1)
        if not isinstance(self.light_samples, int) or self.light_samples < 1:
            raise ValueError(f"light_samples must be a whole number of at least 1, got {self.light_samples}")
        self.features = props.get("features", True)

    def aov_names(self) -> list[str]:
        return list(FEATURE_PLANES) if self.features else []

    def sample(self, scene, sampler, ray, medium=None, active=True):
        # what path carries from bounce to bounce: radiance, throughput, eta, depth, whether the path counts, the
        # previous interaction, its BSDF sample's pdf, whether that was a delta lobe, its emitter samples
        path = (mi.Spectrum(0.0), mi.Spectrum(1.0), mi.Float(1.0), mi.UInt32(0),
                mi.Bool(scene.environment() is not None), dr.zeros(mi.Interaction3f), mi.Float(1.0), mi.Bool(True),
                mi.Float(1.0))
        ray, active = mi.Ray3f(ray), mi.Bool(active)
        hit = scene.ray_intersect_preliminary(ray, True, False, 0, 0, active)
        trace = self._guided if self.features else self._lean
        return trace(scene, sampler, ray, hit, path, active)

    @dr.syntax
    def _guided(self, scene, sampler, ray, hit, path: tuple, active: mi.Bool) -> tuple:
        """The paths from their first preliminary ``hit``, and the first hit's features."""
        # the first bounce before the loop, so that its full interaction gives the features too: read inside the
        # loop they cost a masked BSDF call at every bounce, and a second interaction of their own 2-5% of the paths
        si = hit.compute_surface_interaction(ray, mi.RayFlags.All, active)
        bsdf = si.bsdf(ray)
        features = first_hit_features(si, bsdf)
        path, ray, hit, active = self._bounce(scene, sampler, path, si, bsdf, self.light_samples)
        while dr.hint(active, max_iterations=-1, label="guided_path"):
            si = hit.compute_surface_interaction(ray, mi.RayFlags.All)
            path, ray, hit, active = self._bounce(scene, sampler, path, si, si.bsdf(ray))
        result, valid = path[0], path[4]
        return dr.select(valid, result, 0.0), valid, features

    @dr.syntax
    def _lean(self, scene, sampler, ray, hit, path: tuple, active: mi.Bool) -> tuple:
        """The paths from their first preliminary ``hit``, every bounce the loop's body (no features)."""
        while dr.hint(active, max_iterations=-1, label="guided_path"):
            si = hit.compute_surface_interaction(ray, mi.RayFlags.All)
            first = path[3] == 0  # a missed first ray leaves the loop at once
            path, ray, hit, active = self._bounce(scene, sampler, path, si, si.bsdf(ray),
                                                  dr.select(first, mi.UInt32(self.light_samples), 1))
        result, valid = path[0], path[4]
        return dr.select(valid, result, 0.0), valid, []

    def _bounce(self, scene, sampler, path: tuple, si, bsdf, light_samples: int | mi.UInt32 = 1) -> tuple:
        """One bounce of ``path`` at ``si`` (``bsdf``: its BSDF): the emission reached, emitter sampling
        (``light_samples`` samples, stratified along the first coordinate; a lane's own count where it is an array),
        the BSDF sample, Russian roulette. Returns (``path`` after it, the next ray, its preliminary hit, whether the
        path goes on)."""
        result, throughput, eta, depth, valid, prev_si, prev_pdf, prev_delta, prev_lights = path
        # emission reached by the previous bounce's BSDF sample, weighed against its emitter samples
        emitted = mi.DirectionSample3f(scene, si, prev_si)
        emitter_pdf = scene.pdf_emitter_direction(prev_si, emitted, ~prev_delta)
        mis = _mis_weight(prev_pdf, prev_lights * emitter_pdf)
        result = dr.fma(throughput, emitted.emitter.eval(si, prev_pdf > 0) * mis, result)
        active_next = (depth + 1 < self.max_depth) & si.is_valid()
        # emitter sampling, then one BSDF evaluation and sample for both strategies
        active_emitter = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
        single = isinstance(light_samples, int) and light_samples == 1
        context, lights = mi.BSDFContext(), mi.Float(light_samples)
        direct = mi.Spectrum(0.0) if single else self._lights(scene, sampler, bsdf, si, light_samples, active_emitter)
        sampled, emitter_weight = scene.sample_emitter_direction(
            si, self._stratified(sampler, light_samples - 1, lights, single), True, active_emitter)
        active_emitter &= sampled.pdf != 0
        wo = si.to_local(sampled.d)
        sample_1, sample_2 = sampler.next_1d(), sampler.next_2d()
        bsdf_value, bsdf_pdf, bsdf_sample, bsdf_weight = bsdf.eval_pdf_sample(context, si, wo, sample_1, sample_2)
        emitter_mis = dr.select(sampled.delta, 1.0, _mis_weight(lights * sampled.pdf, bsdf_pdf))
        direct += dr.select(active_emitter, bsdf_value * emitter_weight * emitter_mis, 0.0)
        result = dr.fma(throughput, direct if single else direct / lights, result)
        ray = si.spawn_ray(si.to_world(bsdf_sample.wo))
        throughput = throughput * bsdf_weight
        eta = eta * bsdf_sample.eta
        valid = valid | (si.is_valid() & ~mi.has_flag(bsdf_sample.sampled_type, mi.BSDFFlags.Null))
        depth = dr.select(si.is_valid(), depth + 1, depth)
        # Russian roulette, its sample drawn at every depth as path draws it
        largest = dr.max(throughput)
        survival = dr.minimum(largest * dr.square(eta), 0.95)
        roulette = depth >= self.rr_depth
        survives = sampler.next_1d() < survival
        throughput = dr.select(roulette, throughput * dr.rcp(survival), throughput)
        active = active_next & (~roulette | survives) & (largest != 0)
        path = (result, throughput, eta, depth, valid, mi.Interaction3f(si), bsdf_sample.pdf,
                mi.has_flag(bsdf_sample.sampled_type, mi.BSDFFlags.Delta), lights)
        return path, ray, scene.ray_intersect_preliminary(ray, False, False, 0, 0, active), active

    @staticmethod
    def _stratified(sampler, stratum, strata: mi.Float, single: bool) -> mi.Point2f:
        """The next 2D sample, its first coordinate in the ``stratum``-th of ``strata`` equal parts (``single``: one
        stratum, the sample itself: ``path``'s draw)."""
        sample = sampler.next_2d()
        return sample if single else mi.Point2f((mi.Float(stratum) + sample.x) / strata, sample.y)

    @dr.syntax
    def _lights(self, scene, sampler, bsdf, si, light_samples, active: mi.Bool) -> mi.Spectrum:
        """The sum of the first ``light_samples`` - 1 strata's emitter samples at ``si`` (a lane's own count where it
        is an array), each weighed against the BSDF sample as one of ``light_samples`` (the last stratum shares the
        BSDF's evaluation): one symbolic loop, so that a kernel traced anew (a moving shape's) traces the BSDFs' calls
        once whatever the count."""
        context, lights = mi.BSDFContext(), mi.Float(light_samples)
        direct, stratum = mi.Spectrum(0.0), mi.UInt32(0)
        while dr.hint(stratum + 1 < light_samples, label="light_samples", include=[sampler]):
            sample = self._stratified(sampler, stratum, lights, False)
            sampled, emitter_weight = scene.sample_emitter_direction(si, sample, True, active)
            taken = active & (sampled.pdf != 0)
            value, pdf = bsdf.eval_pdf(context, si, si.to_local(sampled.d), taken)
            mis = dr.select(sampled.delta, 1.0, _mis_weight(lights * sampled.pdf, pdf))
            direct += dr.select(taken, value * emitter_weight * mis, 0.0)
            stratum += 1
        return direct


def guided_twin(integrator: mi.SamplingIntegrator, light_samples: int = 1, features: bool = True) -> GuidedPath | None:
    """A :class:`GuidedPath` tracing what ``integrator`` does (with ``light_samples`` emitter samples at the first
    hit; ``features``: its AOVs), or None where it cannot: anything but Mitsuba's plain ``path`` (read from its
    description), or one that hides emitters."""
    description = str(integrator)
    if not description.startswith("PathIntegrator[") or getattr(integrator, "hide_emitters", True):
        return None
    settings = dict(re.findall(r"(max_depth|rr_depth) = (\d+)", description))
    if set(settings) != {"max_depth", "rr_depth"}:
        return None
    props = mi.Properties()
    props["max_depth"] = int(settings["max_depth"]) if int(settings["max_depth"]) < 2 ** 31 else -1
    props["rr_depth"] = int(settings["rr_depth"])
    props["light_samples"] = light_samples
    props["features"] = features
    return GuidedPath(props)


def twin_of(scene: mi.Scene, integrator: mi.SamplingIntegrator, light_samples: int = 1,
            features: bool = True) -> GuidedPath | None:
    """:func:`guided_twin` of ``integrator``, made once per scene, integrator and settings (the frozen kernels record
    it once)."""
    twins = scene_state(scene).setdefault("guided_twins", {})
    key = (id(integrator), light_samples, features)
    if key not in twins:  # the integrator held: its id stays its own
        for old in making_room(list(twins)):  # a loop that makes an integrator a frame
            del twins[old]
        twins[key] = (integrator, guided_twin(integrator, light_samples, features))
    return twins[key][1]
