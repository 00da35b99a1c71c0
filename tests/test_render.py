"""The masked render against Mitsuba's own path tracer, on the bundled Cornell box."""
import numpy as np
import pytest

from conftest import CORNELL


@pytest.fixture(scope="module")
def cornell(mi):
    from gmcpt.render.scene import load_scene
    return load_scene(CORNELL, resolution=(48, 40))


@pytest.fixture(scope="module")
def path_tracer(mi):
    return mi.load_dict({"type": "path", "max_depth": 8})


def test_rate_one_equals_stock_path(mi, cornell, path_tracer):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    frame, timings = render_sparse_frame(cornell, path_tracer, settings=RenderSettings(rate=1.0, spp=8, seed=7))
    stock = np.asarray(mi.render(cornell, integrator=path_tracer, spp=8, seed=7))[..., :3]
    assert frame.mask.all()
    assert frame.radiance.mean() > 0.01
    np.testing.assert_allclose(frame.radiance, stock, rtol=1e-4, atol=1e-5)
    assert {"features_s", "render_s"} <= timings.keys()


def _plain_pixel_sums(mi, scene, path_tracer, pixels, spp, seed):
    """trace_pixels' sums from the plain (never frozen) function."""
    import drjit as dr
    from gmcpt.render.kernels import camera_key, _pixel_sums

    sensor = scene.sensors()[0]
    sums = _pixel_sums(scene, sensor, path_tracer, mi.UInt32(pixels.astype(np.uint32)),
                       dr.arange(mi.UInt32, pixels.size * spp), mi.UInt32(seed), spp, camera_key(sensor),
                       [dr.zeros(mi.Float, pixels.size) for _ in range(5)])
    return np.stack([np.asarray(column) for column in sums[:3]], axis=1), np.asarray(sums[3])


def test_replayed_trace_equals_a_fresh_trace_for_any_pixel_count_and_seed(mi, cornell, path_tracer):
    """trace_pixels replays a recorded kernel: other pixel counts and seeds must still be traced as asked."""
    from gmcpt.render.kernels import trace_pixels

    sensor = cornell.sensors()[0]
    rng = np.random.default_rng(0)
    for count, seed in ((300, 1), (700, 1), (700, 9), (1920, 4)):
        pixels = np.sort(rng.choice(48 * 40, count, replace=False))
        total, squares, finite = trace_pixels(cornell, sensor, path_tracer, pixels, 4, seed)
        plain_total, plain_squares = _plain_pixel_sums(mi, cornell, path_tracer, pixels, 4, seed)
        assert total.shape == (count, 3) and np.all(finite == 4)
        np.testing.assert_array_equal(total, plain_total)
        np.testing.assert_array_equal(squares, plain_squares)


def test_uneven_samples_sum_into_their_own_pixels(mi, cornell, path_tracer):
    """trace_counts sums each pixel's samples inside the kernel: the same sums as tracing every sample as a lane of
    its own and binning the lanes by pixel, and a pixel given no samples stays empty."""
    from gmcpt.render.kernels import trace_counts, trace_pixels

    sensor = cornell.sensors()[0]
    counts = np.random.default_rng(3).integers(0, 5, 48 * 40)
    total, squares, finite = trace_counts(cornell, sensor, path_tracer, counts, 5)
    lanes = np.repeat(np.arange(counts.size), counts)
    lane_total, lane_squares, lane_finite = trace_pixels(cornell, sensor, path_tracer, lanes, 1, 5)
    binned = lambda values: np.bincount(lanes, weights=values, minlength=counts.size)  # noqa: E731
    np.testing.assert_allclose(total, np.stack([binned(lane_total[:, c]) for c in range(3)], axis=1),
                               rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(squares, binned(lane_squares), rtol=1e-5, atol=1e-4)
    np.testing.assert_array_equal(finite, binned(lane_finite))
    assert total[counts == 0].max() == 0 and total.max() > 0


def test_a_new_spp_reuses_the_compiled_kernels(mi, cornell, path_tracer):
    """A time budget's passes come in sizes the frame picks as it goes: a kernel compiled for each spp (about
    1 s on 2 cores) overran a 1.5-s budget by 70% in CI. Only the recording is new; the kernel is the same."""
    import drjit as dr
    from gmcpt.render.kernels import feature_means, trace_pixels

    sensor, pixels = cornell.sensors()[0], np.arange(0, 48 * 40, 3)
    trace_pixels(cornell, sensor, path_tracer, pixels, 2, 0)
    feature_means(cornell, sensor, 2)
    dr.kernel_history()  # reading it empties it
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        for spp in (5, 11):
            total, _, finite = trace_pixels(cornell, sensor, path_tracer, pixels, spp, 0)
            assert np.all(finite == spp) and total.mean() > 0
            assert feature_means(cornell, sensor, spp).spp == spp
        kernels = [kernel for kernel in dr.kernel_history()
                   if kernel["type"] == dr.KernelType.JIT and kernel["operation_count"] > 100]
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    assert len(kernels) == 4  # the path kernel and the feature kernel, at each spp
    assert all(kernel["cache_hit"] and not kernel["cache_disk"] for kernel in kernels)


def test_pixel_lists_at_any_alignment_replay_one_recording(mi, cornell, path_tracer, monkeypatch):
    """Dr.Jit maps a NumPy array's memory and records a frozen kernel again when an input's alignment changes: pixel
    lists and lane seeds that NumPy placed at other offsets (16-byte steps) replay the one recording, with the plain
    function's sums."""
    from gmcpt.render import kernels

    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    monkeypatch.setattr(kernels, "_frozen_pixel_sums", kernel)
    sensor, storage = cornell.sensors()[0], np.zeros(2048, np.uint32)
    first = (-storage.ctypes.data % 64) // 4
    for words in (0, 4, 8, 12, 1):  # every 16-byte offset within 64 bytes, and an odd word
        pixels = storage[first + words:first + words + 600]
        pixels[:] = np.arange(0, 1800, 3)
        seeds = np.full(600, 7, np.uint32)
        total, squares, _ = kernels.trace_pixels(cornell, sensor, path_tracer, pixels, 1, seeds)
        plain_total, plain_squares = _plain_pixel_sums(mi, cornell, path_tracer, pixels, 1, 7)
        np.testing.assert_array_equal(total, plain_total)
        np.testing.assert_array_equal(squares, plain_squares)
    recordings = kernels.scene_state(cornell)["recordings"]
    assert recordings[kernel.key(path_tracer)].n_recordings == 1


def test_a_scene_whose_kernel_cannot_be_recorded_is_traced_plainly(mi, cornell, path_tracer, monkeypatch):
    """A recording that Dr.Jit refuses (a virtual call it cannot follow) falls back to the plain
    function for that scene: same sums, and no second try at recording it."""
    from gmcpt.render import kernels
    from gmcpt.render.held import scene_state

    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    refusals = []

    def refuse(*arguments):
        refusals.append(1)
        raise RuntimeError("no such object instance was found in the function's inputs")

    recordings = scene_state(cornell).setdefault("recordings", {})
    recordings[kernel.key(path_tracer)] = refuse
    monkeypatch.setattr(kernels, "_frozen_pixel_sums", kernel)
    pixels = np.arange(0, 48 * 40, 3)
    for _ in range(2):
        total, squares, _ = kernels.trace_pixels(cornell, cornell.sensors()[0], path_tracer, pixels, 4, 2)
        plain_total, plain_squares = _plain_pixel_sums(mi, cornell, path_tracer, pixels, 4, 2)
        np.testing.assert_array_equal(total, plain_total)
        np.testing.assert_array_equal(squares, plain_squares)
    assert len(refusals) == 1 and recordings[kernel.key(path_tracer)] is None


def _pixel_sums_arguments(mi, scene, path, pixels, seed):
    """What :class:`~gmcpt.render.kernels.FrozenKernel` over ``_pixel_sums`` is called with: a function building the
    arguments of 4 samples of each of ``pixels`` of ``scene``'s first sensor with the integrator ``path``."""
    from gmcpt.render import kernels

    return lambda: (scene.sensors()[0], path, mi.UInt32(pixels.astype(np.uint32)),
                    kernels.dr.arange(mi.UInt32, pixels.size * 4), kernels.dr.opaque(mi.UInt32, seed), 4,
                    kernels.camera_key(scene.sensors()[0]),
                    [kernels.dr.opaque(mi.Float, 0.0, pixels.size) for _ in range(5)])


def test_a_recording_serves_only_its_own_integrator_even_at_a_freed_ones_address(mi):
    """Integrators made one a call on one scene (a loop that loads one a frame): the recording keyed by the first
    one's id was replayed for the next one, another max_depth, made at the freed one's address."""
    from gmcpt.render.kernels import trace_film_pixels
    from gmcpt.render.scene import load_scene

    pixels = np.repeat(np.arange(16 * 16), 2)

    def traced(scene, depth):
        integrator = mi.load_dict({"type": "path", "max_depth": depth})
        return trace_film_pixels(scene, scene.sensors()[0], integrator, pixels, 0)[0]

    alone = {depth: traced(load_scene(CORNELL, resolution=(16, 16)), depth) for depth in (2, 8)}
    held = load_scene(CORNELL, resolution=(16, 16))
    for depth in (2, 8, 2, 8):
        np.testing.assert_allclose(traced(held, depth), alone[depth], rtol=1e-5, atol=1e-6)


def test_a_recording_serves_only_its_own_scene_and_goes_with_it(mi):
    """A scene loaded again (a batch does it for every frame) gets its own recording: replaying another
    scene's read that scene's freed objects. A scene nobody else holds is let go at the next call, with
    everything the process kept of it."""
    import gc

    from gmcpt.render import held, kernels
    from gmcpt.render.scene import load_scene

    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    pixels = np.arange(0, 24 * 20, 2)
    first = load_scene(CORNELL, resolution=(24, 20))
    path = first.integrator().integrator
    arguments = lambda scene, seed: _pixel_sums_arguments(mi, scene, path, pixels, seed)  # noqa: E731
    kernel(first, arguments(first, 1))
    recording = held.scene_state(first)["recordings"][kernel.key()]
    second = load_scene(CORNELL, resolution=(24, 20))
    sums = kernel(second, arguments(second, 2))
    assert held.scene_state(second)["recordings"][kernel.key()] is not recording
    plain = kernels._pixel_sums(second, *arguments(second, 2)())
    for column, expected in zip(sums, plain):
        np.testing.assert_array_equal(np.asarray(column), np.asarray(expected))
    first_id = id(first)
    del first
    gc.collect()
    kernel(second, arguments(second, 3))
    assert first_id not in held._HELD and id(second) in held._HELD


def test_traced_mean_matches_high_spp_reference(mi, cornell, path_tracer):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    frame, _ = render_sparse_frame(cornell, path_tracer, settings=RenderSettings(rate=0.3, spp=16, seed=3))
    reference = np.asarray(mi.render(cornell, integrator=path_tracer, spp=1024, seed=99))[..., :3]
    traced = frame.mask
    assert traced.sum() == round(0.3 * traced.size)
    assert np.all(frame.radiance[~traced] == 0)
    difference = frame.radiance[traced].mean() - reference[traced].mean()
    # standard error of the traced mean from the recorded per-pixel variances
    standard_error = np.sqrt(frame.variance[traced].sum()) / traced.sum()
    assert abs(difference) < 4 * standard_error + 2e-3
    assert standard_error > 0


@pytest.mark.parametrize("pattern", ["adaptive", "two_pass"])
def test_feature_placements_spend_the_exact_budget_and_repeat_per_seed(mi, cornell, path_tracer, pattern):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    for rate in (0.2, 0.5, 1.0):
        settings = RenderSettings(rate=rate, pattern=pattern, spp=4, seed=5)
        frame, timings = render_sparse_frame(cornell, path_tracer, settings=settings)
        count = round(rate * frame.mask.size)
        assert frame.mask.sum() == count and frame.info.path_samples == count * 4
        assert np.all(frame.radiance[~frame.mask] == 0) and frame.radiance[frame.mask].mean() > 0
        halved = pattern == "two_pass" and rate < 1  # at rate 1 every pixel is traced in one pass
        assert frame.info.first_pass_pixels == (round(count / 2) if halved else count)
        assert "mask_s" in timings
    again, _ = render_sparse_frame(cornell, path_tracer, settings=settings)
    assert np.array_equal(again.mask, frame.mask) and np.array_equal(again.radiance, frame.radiance)
    other, _ = render_sparse_frame(cornell, path_tracer, settings=RenderSettings(rate=0.3, pattern=pattern, spp=4,
                                                                                 seed=6))
    assert not np.array_equal(other.mask, render_sparse_frame(
        cornell, path_tracer, settings=RenderSettings(rate=0.3, pattern=pattern, spp=4, seed=5))[0].mask)


def test_feature_buffers(mi, cornell, path_tracer):
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    frame, _ = render_sparse_frame(cornell, path_tracer, settings=RenderSettings(rate=0.2, spp=1, seed=0))
    hits = frame.depth < 1
    assert hits.mean() > 0.9  # the box fills the view
    assert np.allclose(np.linalg.norm(frame.normal[hits], axis=-1), 1, atol=1e-3)
    assert 0 < frame.depth[hits].min() and frame.depth.max() == pytest.approx(1.0)
    assert 0 <= frame.visibility.min() and frame.visibility.max() <= 1
    assert 0.05 < frame.visibility.mean() < 1  # some shadowed first hits, most lit
    # left wall is red: red albedo dominates in the left tenth of the image
    left = frame.albedo[:, :3][hits[:, :3]]
    assert np.median(left[:, 0]) > 2 * np.median(left[:, 1])


def _poisoned(mi):
    """A path tracer that returns NaN/Inf for about 5% of its samples."""
    import drjit as dr

    class Poisoned(mi.SamplingIntegrator):
        def __init__(self, props):
            super().__init__(props)
            self.inner = mi.load_dict({"type": "path", "max_depth": 4})

        def sample(self, scene, sampler, ray, medium=None, active=True):
            value, valid, aovs = self.inner.sample(scene, sampler, ray, medium, active)
            poison = sampler.next_1d() < 0.05
            value = dr.select(poison, mi.Color3f(dr.nan, dr.inf, 1.0), value)
            return value, valid, aovs

        def to_string(self):
            return "Poisoned[]"

    mi.register_integrator("poisoned", lambda props: Poisoned(props))
    return mi.load_dict({"type": "poisoned"})


def test_nonfinite_samples_do_not_spread(mi, cornell):
    """A nested integrator that returns NaN/Inf for some rays: those samples are dropped."""
    from gmcpt.completion import complete
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    poisoned = _poisoned(mi)
    frame, _ = render_sparse_frame(cornell, poisoned, settings=RenderSettings(rate=0.5, spp=4, seed=1))
    assert frame.info.nonfinite_samples > 0
    assert np.isfinite(frame.radiance).all() and np.isfinite(frame.variance).all()
    result = complete(frame, "interp")
    assert np.isfinite(result.image).all()


def _sphere_scene(mi, bsdf: dict):
    """A sphere filling the middle of a 32x32 view against an empty background, lit by a constant sky."""
    return mi.load_dict({
        "type": "scene", "integrator": {"type": "path"},
        "sensor": {"type": "perspective", "fov": 40,
                   "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 32, "height": 32}, "sampler": {"type": "independent"}},
        "sphere": {"type": "sphere", "radius": 0.8, "bsdf": bsdf},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 1.0}}})


def test_albedo_is_diffuse_reflectance_only(mi):
    """A rough metal has no diffuse albedo (Mitsuba's default estimate gives it values far above 1)."""
    from gmcpt.render.kernels import render_features

    rough_metal = {"type": "roughconductor", "alpha": 0.05}
    metal = render_features(s := _sphere_scene(mi, rough_metal), s.sensors()[0], feature_spp=4)
    assert np.all(metal["albedo"] == 0) and np.all(metal["coverage"] == 0)
    red = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.7, 0.2, 0.1]}}
    matte = render_features(s := _sphere_scene(mi, red), s.sensors()[0], feature_spp=4)
    inside = matte["coverage"] == 1
    np.testing.assert_allclose(matte["albedo"][inside], np.broadcast_to([0.7, 0.2, 0.1], (inside.sum(), 3)), rtol=1e-5)
    assert matte["albedo"].max() <= 1


def test_coverage_is_the_fraction_of_rays_on_the_diffuse_surface(mi):
    from gmcpt.render.kernels import render_features

    gray = {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.5}}
    features = render_features(s := _sphere_scene(mi, gray), s.sensors()[0], feature_spp=16)
    coverage, albedo = features["coverage"], features["albedo"][..., 0]
    assert coverage[16, 16] == 1 and coverage[0, 0] == 0
    silhouette = (coverage > 0) & (coverage < 1)
    assert silhouette.sum() > 20  # the sphere's rim: partly sphere, partly background
    # the albedo buffer averages over all rays (0 on a miss), so on the rim it is coverage x 0.5
    np.testing.assert_allclose(albedo[silhouette], 0.5 * coverage[silhouette], rtol=1e-5)


def test_a_scene_with_an_exr_loads_with_one_drjit_thread(mi, tmp_path):
    """With one Dr.Jit thread Mitsuba's EXR reader never returned (an environment map): load_scene lends it
    a second thread while loading, and gives the count back."""
    import subprocess
    import sys

    from conftest import ROOT

    mi.Bitmap(np.full((8, 16, 3), 0.5, np.float32)).write(str(tmp_path / "sky.exr"))
    scene = CORNELL.read_text().replace("</scene>", '<emitter type="envmap"><string name="filename" '
                                                     'value="sky.exr"/></emitter></scene>')
    (tmp_path / "scene.xml").write_text(scene)
    code = ("import sys, gmcpt, drjit as dr; from gmcpt.render.scene import load_scene; dr.set_thread_count(1); "
            "load_scene(sys.argv[1], (8, 8)); print('threads', dr.thread_count())")
    result = subprocess.run([sys.executable, "-c", code, str(tmp_path / "scene.xml")], capture_output=True,
                            text=True, timeout=120, cwd=ROOT)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "threads 1"


def test_a_scene_loads_its_emitters_in_the_same_order_every_time(mi, tmp_path):
    """Mitsuba's shape merging put the merged scene's area emitters in a new order on each load (4 orders in 8
    loads of this scene), and emitter sampling with them: the same seed gave another image in the next process.
    load_scene keeps the document's order."""
    from gmcpt.render.scene import load_scene

    (tmp_path / "quad.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n"
                                       "f 1//1 3//1 4//1\n")

    def quad(x: int, y: int, emitter: str = "") -> str:
        return (f'<shape type="obj"><string name="filename" value="quad.obj"/><transform name="to_world">'
                f'<translate x="{x}" y="{y}" z="-3"/></transform><ref id="grey"/>{emitter}</shape>')

    lights = [f'<emitter type="area" id="light{index}"><rgb name="radiance" value="{index + 1}"/></emitter>'
              for index in range(4)]
    shapes = [quad(index, 0) for index in range(6)] + [quad(index, 3, light) for index, light in enumerate(lights)]
    (tmp_path / "scene.xml").write_text(
        '<scene version="3.0.0"><bsdf type="diffuse" id="grey"/><sensor type="perspective"><film type="hdrfilm">'
        '<integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>'
        + "".join(shapes) + "</scene>")
    orders = {tuple(emitter.id() for emitter in load_scene(tmp_path / "scene.xml").emitters()) for _ in range(8)}
    assert orders == {("light0", "light1", "light2", "light3")}


def test_a_meshs_computed_normals_are_the_same_bits_on_every_load(mi, tmp_path):
    """Mitsuba sums the normals of a mesh whose file has none with float atomics over its threads: 6 loads of this
    one gave 2-4 different normals. load_scene sums them again on one thread; normals a file gives stay its own."""
    from conftest import write_blob
    from gmcpt.render.scene import load_scene

    write_blob(tmp_path / "blob.obj")
    tilted = "vn 0.4 0 0.9165\nvn -0.3 0.2 0.9327\nvn 0.1 -0.5 0.86\n"  # far from the face's own
    (tmp_path / "tri.obj").write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\n" + tilted + "f 1//1 2//2 3//3\n")
    (tmp_path / "scene.xml").write_text(
        '<scene version="3.0.0"><sensor type="perspective"/><shape type="obj" id="blob"><string name="filename" '
        'value="blob.obj"/></shape><shape type="obj" id="tri"><string name="filename" value="tri.obj"/></shape>'
        '</scene>')
    loads = [mi.traverse(load_scene(tmp_path / "scene.xml")) for _ in range(6)]
    blobs = {np.array(loaded["blob.vertex_normals"]).tobytes() for loaded in loads}
    assert len(blobs) == 1
    normals = np.array(loads[0]["tri.vertex_normals"]).reshape(-1, 3)
    assert np.allclose(normals[0], np.array([0.4, 0, 0.9165]) / np.linalg.norm([0.4, 0, 0.9165]), atol=1e-6)


def test_a_top_up_folds_into_a_native_mean_as_the_sums_would(mi, cornell, path_tracer):
    """A dense frame's sums stay Mitsuba's float32 mean while only native passes and pixel-list top-ups come: the
    mean is each pixel's native samples and its top-up's together, the top-up's squares are dropped, and the
    float64 sums made afterwards (another kind of pass) agree with it."""
    from gmcpt.render.kernels import SampleSums, render_native, trace_pixels

    sensor = cornell.sensors()[0]
    pixels = np.arange(0, 48 * 40, 3)
    native = render_native(cornell, sensor, path_tracer, 2, 5)
    top_sum, _, top_count = trace_pixels(cornell, sensor, path_tracer, pixels, 1, 7)
    sums = SampleSums(48 * 40)
    sums.add_native(native, 2)
    sums.trace(cornell, sensor, path_tracer, pixels, 1, 7)
    mean, variance = sums.estimate()
    expected = native.astype(np.float64) * 2
    expected[pixels] += top_sum
    counts = np.full(48 * 40, 2.0)
    counts[pixels] += top_count
    np.testing.assert_allclose(mean, expected / counts[:, None], rtol=1e-5, atol=1e-6)
    assert not variance.any() and sums.samples == 2 * 48 * 40 + pixels.size
    np.testing.assert_allclose(sums.total, expected, rtol=1e-5, atol=1e-6)


def test_every_pixel_through_the_frozen_kernel_is_mitsubas_render(mi, cornell, monkeypatch):
    """Below its size the frozen kernel stands in for mi.render: the same image for the same seed, and a pixel with
    a non-finite sample non-finite too, so that its samples count as dropped as they did."""
    from gmcpt.render import kernels

    poisoned, sensor = _poisoned(mi), cornell.sensors()[0]
    frozen = kernels.render_native(cornell, sensor, poisoned, 2, 3)
    monkeypatch.setattr(kernels, "FROZEN_FRAME_SAMPLES", 0)
    native = kernels.render_native(cornell, sensor, poisoned, 2, 3)
    finite = np.isfinite(native).all(axis=1)
    assert 0 < finite.sum() < finite.size
    np.testing.assert_array_equal(np.isfinite(frozen).all(axis=1), finite)
    np.testing.assert_allclose(frozen[finite], native[finite], rtol=1e-5, atol=1e-6)


def test_a_shape_moved_through_traverse_is_traced_where_it_is_now(mi):
    """A recording replayed after a shape moved traced the old geometry: NaN pixels in the living room (a real
    interior: the bundled scenes did not show it) after four moves of one of its meshes. The kernel follows the
    shape, as Mitsuba's own render does, frame after frame."""
    import drjit as dr

    from gmcpt.evaluation.scenes import evaluation_scenes
    from gmcpt.render.kernels import render_native
    from gmcpt.render.scene import path_integrator

    found = [s for s in evaluation_scenes(None, 2) if s.name == "living-room" and s.available()]
    if not found:
        pytest.skip("the living room is not imported (scripts/import_scenes.py)")
    scene = found[0].load(48)
    sensor, integrator, parameters = scene.sensors()[0], path_integrator(scene), mi.traverse(scene)
    key = next(key for key in parameters.keys() if key.endswith("vertex_positions"))
    base = np.array(parameters[key])
    for frame in range(6):
        parameters[key] = mi.Float(base + np.float32(0.04 * frame))
        dr.make_opaque(parameters[key])
        parameters.update()
        ours = render_native(scene, sensor, integrator, 4, 5)
        theirs = np.asarray(mi.render(scene, integrator=integrator, spp=4, seed=5)).reshape(-1, 3)
        np.testing.assert_allclose(ours, theirs, rtol=1e-4, atol=1e-5)


def test_an_animated_scene_runs_its_kernels_plainly_and_a_still_one_replays_them(mi):
    """A kernel records while its scene keeps still and replays that recording; a shape moved through ``mi.traverse``
    drops it, and after :data:`~gmcpt.render.kernels.ANIMATED_MOVES` moves the scene is an animation: the kernel runs
    the plain function for it, still calls too (a recording would serve one frame), and its sums stay the plain
    function's. Once the shapes stop moving for :data:`~gmcpt.render.kernels.STILL_CALLS` calls, it records again."""
    from gmcpt.render import held, kernels
    from gmcpt.render.scene import load_scene

    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    pixels = np.arange(0, 24 * 20, 2)
    scene = load_scene(CORNELL, resolution=(24, 20))
    path, parameters = scene.integrator().integrator, mi.traverse(scene)
    key = "tall_block.vertex_positions"
    base = np.array(parameters[key])
    arguments = _pixel_sums_arguments(mi, scene, path, pixels, 3)
    recordings = held.scene_state(scene).setdefault("recordings", {})

    def move(step):
        parameters[key] = mi.Float(base + np.float32(0.05 * step))
        parameters.update()

    for _ in range(2):
        kernel(scene, arguments)
    assert kernel.key() in recordings  # a still scene replays
    for step in range(1, kernels.ANIMATED_MOVES + 1):
        move(step)
        for _ in range(2):
            sums = kernel(scene, arguments)
        assert (kernel.key() in recordings) == (step < kernels.ANIMATED_MOVES)
    plain = kernels._pixel_sums(scene, *arguments())
    for column, expected in zip(sums, plain):
        np.testing.assert_array_equal(np.asarray(column), np.asarray(expected))
    for _ in range(kernels.STILL_CALLS - 2):  # one still call since the last move, above
        kernel(scene, arguments)
    assert kernel.key() not in recordings
    kernel(scene, arguments)  # the last still call: the animation stopped
    assert kernel.key() in recordings
    for column, expected in zip(kernel(scene, arguments), plain):
        np.testing.assert_array_equal(np.asarray(column), np.asarray(expected))


def test_a_moved_sphere_keeps_its_recording_and_replays_the_plain_functions_sums(mi):
    """A shape other than a mesh (here a sphere, through its ``to_world``) that moved does not drop the recording:
    the replay traces it where it is now, to the bit of the plain function, move after move."""
    import drjit as dr

    from gmcpt.render import held, kernels
    from gmcpt.render.scene import load_scene

    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    pixels = np.arange(0, 24 * 20, 2)
    scene = load_scene(CORNELL, resolution=(24, 20))
    path, parameters = scene.integrator().integrator, mi.traverse(scene)
    key = "metal_sphere.to_world"
    base = mi.ScalarTransform4f(np.array(parameters[key].matrix).reshape(4, 4))
    arguments = _pixel_sums_arguments(mi, scene, path, pixels, 3)
    recordings = held.scene_state(scene).setdefault("recordings", {})
    first = None
    for step in range(kernels.ANIMATED_MOVES + 2):
        moved = mi.AffineTransform4f(mi.ScalarTransform4f().translate([0.06 * step, 0.0, -0.04 * step]) @ base)
        dr.make_opaque(moved)
        parameters[key] = moved
        parameters.update()
        sums = [np.asarray(column) for column in kernel(scene, arguments)]
        assert kernel.key() in recordings
        plain = kernels._pixel_sums(scene, *arguments())
        for column, expected in zip(sums, plain):
            np.testing.assert_array_equal(column, np.asarray(expected))
        first = sums[0] if first is None else first
    assert not np.array_equal(first, sums[0])  # the sphere moved in the image


def test_a_mesh_moved_inside_a_shape_group_drops_the_recording(mi):
    """An instance's shapes are not among ``scene.shapes()``: a mesh of a shape group moved through ``mi.traverse``
    still drops the kernel's recording, and the kernel traces it where it is now."""
    from gmcpt.render import held, kernels

    transform = mi.ScalarTransform4f
    scene = mi.load_dict({
        "type": "scene",
        "sensor": {"type": "perspective", "to_world": transform().look_at(origin=[0, 1, 4], target=[0, 0, 0],
                                                                          up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": 24, "height": 20, "rfilter": {"type": "box"}}},
        "sky": {"type": "constant"},
        "group": {"type": "shapegroup", "box": {"type": "cube", "to_world": transform().scale(0.5)}},
        "placed": {"type": "instance", "shapegroup": {"type": "ref", "id": "group"}},
        "floor": {"type": "rectangle", "to_world": transform().translate([0, -0.5, 0]).rotate([1, 0, 0], -90).scale(3)},
    })
    kernel = kernels.FrozenKernel(kernels._pixel_sums)
    path = mi.load_dict({"type": "path", "max_depth": 4})
    arguments = _pixel_sums_arguments(mi, scene, path, np.arange(24 * 20), 3)
    recordings = held.scene_state(scene).setdefault("recordings", {})
    for _ in range(2):
        before = [np.asarray(column) for column in kernel(scene, arguments)]
    assert kernel.key() in recordings
    parameters = mi.traverse(scene)
    parameters["group.box.vertex_positions"] = mi.Float(np.array(parameters["group.box.vertex_positions"])
                                                        + np.float32(0.4))
    parameters.update()
    after = [np.asarray(column) for column in kernel(scene, arguments)]
    assert kernel.key() not in recordings  # dropped, as a mesh's move drops it (a mesh's replay can be stale)
    plain = kernels._pixel_sums(scene, *arguments())
    for column, expected in zip(after, plain):
        np.testing.assert_array_equal(column, np.asarray(expected))
    assert not np.array_equal(after[0], before[0])


def test_the_frame_info_writes_the_sidecars_entries_in_their_order():
    """:meth:`gmcpt.frame.FrameInfo.to_json`: a budget's readings even where not read (null), a time budget's spent
    samples, ``two_pass``'s first pass, nothing a strategy did not record; an unknown field is refused."""
    from gmcpt.frame import FrameInfo

    counts = {"traced_pixels": 4, "path_samples": 8, "nonfinite_samples": 0}
    rate = FrameInfo(pattern="random", first_pass_pixels=4, **counts)
    assert list(rate.to_json()) == ["traced_pixels", "path_samples", "nonfinite_samples"]
    budget = rate.with_values(pattern="two_pass", budget=4.8, budget_choice="dense", probe="none", guide_spp=4,
                              costs={"path": 1.0})
    assert budget.to_json() == {**{key: value for key, value in counts.items() if key != "nonfinite_samples"},
                                "budget_choice": "dense", "probe": "none", "relative_variance": None,
                                "edge_share": None, "guide_spp": 4, "costs": {"path": 1.0}, "first_pass_pixels": 4,
                                "nonfinite_samples": 0}
    timed = rate.with_values(time_budget=0.5, budget=7.0, budget_choice="dense", guide_spp=7, time_spent=0.4)
    assert list(timed.to_json())[2:] == ["budget_choice", "guide_spp", "time_spent", "spent_budget",
                                         "nonfinite_samples"]
    with pytest.raises(TypeError):
        rate.with_values(guide_aliasing=1.0)
