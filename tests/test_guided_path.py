"""The path tracer that brings OIDN's guides from its own first hits (gmcpt.render.guided_path) and the dense frames
that take their guides from it."""
import numpy as np
import pytest

from budget_helpers import SIZE, render_budget
from conftest import CORNELL, STILL_LIFE


def _scene_and_twin(path, size=SIZE):
    from gmcpt.render.guided_path import guided_twin
    from gmcpt.render.scene import load_scene, path_integrator

    scene = load_scene(path, resolution=size)
    integrator = path_integrator(scene)
    return scene, integrator, guided_twin(integrator)


@pytest.mark.parametrize("frozen", [True, False])
@pytest.mark.parametrize("path", [CORNELL, STILL_LIFE])
def test_the_twin_renders_the_integrators_image_to_the_bit(mi, monkeypatch, path, frozen):
    from gmcpt.render import kernels

    if not frozen:  # through mi.render and its film instead of the pixel-list kernel
        monkeypatch.setattr(kernels, "FROZEN_FRAME_SAMPLES", 0)
    scene, integrator, twin = _scene_and_twin(path)
    sensor = scene.sensors()[0]
    for spp, seed in ((1, 0), (3, 11)):
        image = kernels.render_native(scene, sensor, integrator, spp, seed)
        same, guides = kernels.render_native_guided(scene, sensor, twin, spp, seed)
        if frozen:  # the same samples, summed alike
            np.testing.assert_array_equal(same, image)
        else:  # the film develops more channels: the last bit of a pixel may differ
            np.testing.assert_allclose(same, image, rtol=1e-6, atol=1e-12)
        assert guides.spp == spp and guides.visibility is None
    assert not np.array_equal(kernels.render_native(scene, sensor, integrator, 1, 1), image[:, :3])


def test_the_twins_guides_are_the_feature_pass_buffers(mi):
    from gmcpt.render import kernels

    scene, _, twin = _scene_and_twin(STILL_LIFE, (64, 64))
    sensor = scene.sensors()[0]
    _, guides = kernels.render_native_guided(scene, sensor, twin, 64, 3)
    passed = kernels.feature_means(scene, sensor, 64, 5, visibility=False)
    mine, theirs = guides.buffers(), passed.buffers()
    for name in ("albedo", "normal", "depth", "coverage"):  # other rays, the same quantities: means of 64 agree
        assert np.abs(mine[name] - theirs[name]).mean() < 0.01, name
    # one ray a pixel: the first hit's own values (a pixel inside a flat wall reads the wall's albedo exactly)
    _, one = kernels.render_native_guided(scene, sensor, twin, 1, 3)
    albedo = one.buffers()["albedo"]
    assert np.isin(albedo[30:34, 30:34], albedo).all() and albedo.max() <= 1.0


def test_only_a_plain_path_tracer_that_shows_its_emitters_has_a_twin(mi):
    from gmcpt.render.guided_path import guided_twin

    twin = guided_twin(mi.load_dict({"type": "path", "max_depth": 7, "rr_depth": 3}))
    assert (twin.max_depth, twin.rr_depth) == (7, 3)
    assert guided_twin(mi.load_dict({"type": "path"})).max_depth == 0xFFFFFFFF  # unbounded
    assert guided_twin(mi.load_dict({"type": "path", "hide_emitters": True})) is None
    assert guided_twin(mi.load_dict({"type": "direct"})) is None


def test_a_dense_frame_takes_its_guides_from_its_render(mi, monkeypatch):
    """Budget 16 is dense without a choice: its render's 16 first hits are the guides, and no guide pass runs; the
    image is the one the frame makes with a guide pass."""
    from gmcpt.sampling import budget, dense, trace
    from gmcpt.render import kernels
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", np.inf)  # even: a first launch of 10 spp, then one of 6
    passes = []
    means = kernels.feature_means
    monkeypatch.setattr(trace, "feature_means", lambda *args, **kw: passes.append(args[2]) or means(*args, **kw))
    frame = render_budget(load_scene(CORNELL, resolution=SIZE), 16)
    assert frame.info.guides == "render" and frame.info.guide_spp == 16 and passes == []
    monkeypatch.setattr(dense, "twin_of", lambda scene, integrator: None)
    passed = render_budget(load_scene(CORNELL, resolution=SIZE), 16)
    assert passed.info.guides == "pass" and passes == [16]
    np.testing.assert_array_equal(frame.radiance, passed.radiance)
    assert np.abs(frame.albedo - passed.albedo).mean() < 0.02 and not np.array_equal(frame.albedo, passed.albedo)


def test_an_adaptive_dense_frame_tops_its_first_launchs_guides_up(mi, monkeypatch):
    """Where the rest of a dense frame goes where the error is, only its first launch brings guide rays."""
    from gmcpt.sampling import budget, trace
    from gmcpt.render import kernels
    from gmcpt.render.scene import load_scene

    monkeypatch.setattr(budget, "ADAPTIVE_ABOVE", 0.0)  # any concentration pays
    passes = []
    means = kernels.feature_means
    monkeypatch.setattr(trace, "feature_means", lambda *args, **kw: passes.append(args[2]) or means(*args, **kw))
    frame = render_budget(load_scene(CORNELL, resolution=SIZE), 16)
    assert frame.info.dense_placement == "adaptive" and frame.info.guides == "render"
    assert passes == [6] and frame.info.guide_spp == 16  # 10 from the first launch


def test_guides_from_the_render_are_topped_up_to_the_rays_the_budget_asks(mi, monkeypatch):
    """Budget 1 wants 4 rays: the render brings one, a pass the other three, from a scene's first frame on."""
    from gmcpt.render import kernels
    from gmcpt.sampling import trace
    from gmcpt.render.scene import load_scene

    passes = []
    means = kernels.feature_means
    monkeypatch.setattr(trace, "feature_means", lambda *args, **kw: passes.append(args[2]) or means(*args, **kw))
    scene = load_scene(CORNELL, resolution=SIZE)
    first, second = render_budget(scene, 1), render_budget(scene, 1)
    assert passes == [3, 3]
    assert first.info.guides == second.info.guides == "render"
    assert first.info.guide_spp == second.info.guide_spp == 4


def _sun_and_sky(mi):
    """A floor under a small bright sphere light and a dim constant sky: one emitter sample picks either."""
    return mi.load_dict({
        "type": "scene",
        "sensor": {"type": "perspective", "fov": 50,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, -3, 3], target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": 24, "height": 24, "rfilter": {"type": "box"}}},
        "floor": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale(4),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.6}}},
        "sun": {"type": "sphere", "center": [2, 1, 4], "radius": 0.2,
                "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 200.0}}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.2}},
        "integrator": {"type": "path"},
    })


def test_more_light_samples_at_the_first_hit_keep_the_image_and_take_the_noise(mi):
    """Several emitter samples at the first hit estimate the same image as ``path`` (its mean within the noise) with
    less noise where one sample picks the sun or the sky; one light sample is ``path`` to the bit."""
    from gmcpt.render import kernels
    from gmcpt.render.guided_path import guided_twin

    scene = _sun_and_sky(mi)
    sensor, integrator = scene.sensors()[0], scene.integrator()
    twin, lit = guided_twin(integrator), guided_twin(integrator, 4)
    np.testing.assert_array_equal(kernels.render_native(scene, sensor, twin, 2, 5),
                                  kernels.render_native(scene, sensor, integrator, 2, 5))
    frames = {name: np.stack([kernels.render_native(scene, sensor, tracer, 1, seed).mean(axis=1)
                              for seed in range(64)])
              for name, tracer in (("path", integrator), ("four", lit))}
    means = {name: float(values.mean()) for name, values in frames.items()}
    assert abs(means["four"] - means["path"]) < 0.03 * means["path"], means
    noise = {name: float(values.var(axis=0).mean()) for name, values in frames.items()}
    assert noise["four"] < 0.5 * noise["path"], noise
    with pytest.raises(ValueError, match="light_samples"):
        guided_twin(integrator, 0)


def test_each_integrator_replays_its_own_recording(mi):
    """Two twins that differ in their light samples alone trace their own paths through the frozen kernel: Dr.Jit
    would replay the first one's recording for the second."""
    from gmcpt.render.guided_path import twin_of
    from gmcpt.render.kernels import trace_counts

    scene = _sun_and_sky(mi)
    sensor, integrator = scene.sensors()[0], scene.integrator()
    counts = np.ones(24 * 24, np.int64)
    traced = [trace_counts(scene, sensor, twin_of(scene, integrator, samples), counts, 5)[0] for samples in (8, 4, 8)]
    assert not np.array_equal(traced[0], traced[1])
    np.testing.assert_array_equal(traced[0], traced[2])


def test_the_twin_without_features_is_one_loop_of_the_same_paths(mi):
    """Without its AOVs the twin's first bounce is the loop's: ``path``'s image to the bit with one light sample, and
    with eight the first-hit twin's samples to float rounding (the same draws in the same order)."""
    from gmcpt.render import kernels
    from gmcpt.render.guided_path import guided_twin

    scene = _sun_and_sky(mi)
    sensor, integrator = scene.sensors()[0], scene.integrator()
    lean = guided_twin(integrator, 1, features=False)
    assert lean.aov_names() == []
    np.testing.assert_array_equal(kernels.render_native(scene, sensor, lean, 2, 5),
                                  kernels.render_native(scene, sensor, integrator, 2, 5))
    np.testing.assert_allclose(kernels.render_native(scene, sensor, guided_twin(integrator, 8, features=False), 2, 5),
                               kernels.render_native(scene, sensor, guided_twin(integrator, 8), 2, 5), rtol=1e-5,
                               atol=1e-6)
