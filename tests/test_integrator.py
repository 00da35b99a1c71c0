"""masked_path as a Mitsuba plugin: XML scenes, mi.load_file + mi.render."""
import numpy as np
import pytest

from conftest import CORNELL, STILL_LIFE
from gmcpt.errors import GmcptError


@pytest.mark.parametrize("scene_file", [CORNELL, STILL_LIFE], ids=["cornell-box", "still-life"])
def test_bundled_scene_renders_through_mi_render(mi, scene_file):
    from gmcpt.io.exr import channel_names, unpack
    from mitsuba_plugins import MaskedPathIntegrator

    # 64 px, not fewer: at 40 px the Cornell box's light and walls are a few pixels each and the
    # denoised traced pixels' mean wandered 5-20% from their samples' with the mask's seed
    scene = mi.load_file(str(scene_file), res=64, spp=4, rate=0.25)
    integrator = scene.integrator()
    assert isinstance(integrator, MaskedPathIntegrator)
    tensor = np.asarray(mi.render(scene))
    assert tensor.shape == (64, 64, len(channel_names()))
    frame, image = unpack(tensor)
    assert frame.mask.sum() == round(0.25 * 64 * 64)
    assert np.isfinite(image).all() and image.mean() > 0.01
    assert integrator.completion == "gan_oidn"  # the default: fills the others, OIDN denoises every pixel
    assert (image[~frame.mask].sum(axis=-1) > 0).mean() > 0.5
    assert not np.allclose(image[frame.mask], frame.radiance[frame.mask])
    # the denoised traced pixels keep their samples' brightness as displayed (clamped to [0, 1]); in
    # linear radiance the light's few clipped pixels (2% of the traced ones at 64 px, 14x brighter
    # than the walls) dominate the mean, and smoothing their edges moved it by 13%. Display-range ratio with
    # 16-spp guides over seeds 0-3: 1.02-1.06 for cornell-box, 0.99 for still-life; above 1 because clamping
    # 4-spp samples darkens their displayed mean (Jensen), the more so the cleaner OIDN gets the pixels
    clamped = lambda values: np.clip(values, 0.0, 1.0).mean()  # noqa: E731
    assert abs(clamped(image[frame.mask]) / clamped(frame.radiance[frame.mask]) - 1) < 0.08
    integrator.completion = "interp"  # keeps the traced pixels as rendered
    frame, image = unpack(np.asarray(mi.render(scene)))
    np.testing.assert_allclose(image[frame.mask], frame.radiance[frame.mask], rtol=1e-6)
    assert integrator.aov_names() == channel_names()[3:]
    assert {"features_s", "render_s", "completion_s"} <= integrator.last_timings.keys()


def test_same_seed_same_image(mi):
    scene = mi.load_file(str(CORNELL), res=24, spp=2)
    first, second = np.asarray(mi.render(scene, seed=5)), np.asarray(mi.render(scene, seed=5))
    other = np.asarray(mi.render(scene, seed=6))
    assert np.array_equal(first, second)
    assert not np.array_equal(first, other)


def test_a_scene_from_mi_load_file_renders_with_the_same_normals_every_load(mi, tmp_path):
    """A mesh whose file has no normals gets them from Mitsuba, other bits on each load (float atomics): masked_path
    sums them again on one thread at the scene's first render, as load_scene does, so mi.load_file + mi.render
    repeats too."""
    from conftest import write_blob

    write_blob(tmp_path / "blob.obj")
    (tmp_path / "scene.xml").write_text(
        '<scene version="3.0.0"><integrator type="masked_path"><float name="rate" value="1"/>'
        '<string name="completion" value="interp"/></integrator><sensor type="perspective">'
        '<transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>'
        '<sampler type="independent"><integer name="sample_count" value="1"/></sampler><film type="hdrfilm">'
        '<integer name="width" value="16"/><integer name="height" value="16"/></film></sensor>'
        '<shape type="obj" id="blob"><string name="filename" value="blob.obj"/></shape>'
        '<shape type="obj"><string name="filename" value="blob.obj"/><transform name="to_world"><translate x="3"/>'
        '</transform></shape><emitter type="constant"/></scene>')  # a second mesh loaded beside it: they race
    normals = set()
    for _ in range(6):
        scene = mi.load_file(str(tmp_path / "scene.xml"))
        mi.render(scene)
        normals.add(np.array(mi.traverse(scene)["blob.vertex_normals"]).tobytes())
    assert len(normals) == 1


def test_properties_are_validated(mi):
    from gmcpt.errors import GmcptError

    base = {"type": "masked_path"}
    for bad, message in [({"rate": 1.5}, "rate"), ({"mask": "grid"}, "mask pattern"),
                         ({"completion": "magic"}, "completion method"), ({"feature_spp": 0}, "feature_spp")]:
        with pytest.raises((GmcptError, RuntimeError), match=message):
            mi.load_dict({**base, **bad})


def test_default_nested_integrator_takes_depth_settings(mi):
    integrator = mi.load_dict({"type": "masked_path", "max_depth": 3, "rr_depth": 2})
    assert "max_depth = 3" in str(integrator.integrator)
    with pytest.raises((RuntimeError, Exception), match="nested integrator"):
        mi.load_dict({"type": "masked_path", "max_depth": 3, "inner": {"type": "path"}})


def test_feature_pass_defaults_to_antialiased_features(mi):
    from gmcpt.evaluation.config import QUICK
    from gmcpt.render.kernels import DEFAULT_FEATURE_SPP
    from gmcpt.sampling.strategies import RenderSettings

    assert DEFAULT_FEATURE_SPP > 1  # 1 spp aliases albedo at edges against the antialiased radiance
    integrator = mi.load_dict({"type": "masked_path"})
    assert integrator.feature_spp == RenderSettings().feature_spp == QUICK.feature_spp == DEFAULT_FEATURE_SPP
    assert mi.load_dict({"type": "masked_path", "feature_spp": 1}).settings().feature_spp == 1


def test_weights_property_is_checked_at_load_and_reaches_the_gan(mi, tmp_path):
    from gmcpt.gan.weights import weights_path

    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(weights_path("gan-cpu").read_bytes()[:3000])
    for bad, message in [({"weights": str(truncated)}, "corrupt or incompatible"),
                         ({"weights": str(tmp_path / "absent.pt")}, "not found"),
                         ({"weights": "gan-cpu", "completion": "pawnnm"}, "GAN methods only")]:
        with pytest.raises((GmcptError, RuntimeError), match=message):
            mi.load_dict({"type": "masked_path", **bad})
    assert mi.load_dict({"type": "masked_path"}).completion_options() == {"tile": 1024}
    # other weights (an untrained generator of the same shape) change the completed pixels
    import torch
    from gmcpt.gan.model import Generator
    from gmcpt.gan.weights import load_generator, save_weights
    from gmcpt.io.exr import unpack
    from gmcpt.render.scene import masked_integrator

    torch.manual_seed(0)
    other = tmp_path / "untrained.pt"
    save_weights(other, Generator(load_generator("gan-cpu")[0].config), {})
    scene = mi.load_file(str(CORNELL), res=40, spp=4, rate=0.25)
    images = {}
    for weights in ("gan-cpu", str(other)):
        integrator = masked_integrator(scene, weights=weights)
        assert integrator.completion_options() == {"tile": 1024, "weights": weights}
        frame, images[weights] = unpack(np.asarray(mi.render(scene, integrator=integrator)))
    assert not np.allclose(images["gan-cpu"][~frame.mask], images[str(other)][~frame.mask])
