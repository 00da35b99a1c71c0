"""scripts/import_scenes.py: Mitsuba 0.6 snippets in, loadable Mitsuba 3 scenes and one README line per change out."""
import importlib.util
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import ROOT

SCRIPT = ROOT / "scripts" / "import_scenes.py"

SCENE_06 = """<?xml version="1.0"?>
<scene version="0.6.0">
	<default name="method" value="sppm"/>
	<default name="spp" value="4"/>
	<integrator type="$method">
		<integer name="maxDepth" value="5"/>
		<integer name="photonCount" value="1000"/>
	</integrator>
	<sensor type="perspective">
		<string name="fovAxis" value="smaller"/>
		<float name="fov" value="40"/>
		<transform name="toWorld"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
		<sampler type="ldsampler"><integer name="sampleCount" value="$spp"/></sampler>
		<film type="ldrfilm">
			<integer name="width" value="32"/><integer name="height" value="24"/>
			<boolean name="banner" value="false"/><float name="gamma" value="2.2"/>
		</film>
	</sensor>
	<bsdf type="dielectric" id="glass">
		<float name="intIOR" value="1.5"/><float name="extIOR" value="1.0"/><float name="alpha" value="0.1"/>
	</bsdf>
	<bsdf type="ward" id="lacquer">
		<rgb name="diffuseReflectance" value="0.3 0.3 0.3"/><rgb name="specularReflectance" value="0.1 0.1 0.1"/>
		<float name="alpha" value="0.3"/>
	</bsdf>
	<bsdf type="roughconductor" id="gold">
		<string name="material" value="Au"/><float name="extEta" value="1"/>
	</bsdf>
	<bsdf type="diffuse" id="tiles">
		<texture name="reflectance" type="bitmap">
			<string name="filename" value="textures/tiles.exr"/><string name="filterType" value="trilinear"/>
		</texture>
	</bsdf>
	<shape type="sphere"><float name="radius" value="1"/><ref id="tiles"/></shape>
	<shape type="sphere">
		<point name="center" x="1.2" y="0.6" z="1"/><float name="radius" value="0.3"/><ref id="glass"/>
	</shape>
	<shape type="sphere">
		<point name="center" x="-1.2" y="0.6" z="1"/><float name="radius" value="0.3"/><ref id="lacquer"/>
	</shape>
	<shape type="sphere">
		<point name="center" x="0" y="-1.3" z="1"/><float name="radius" value="0.3"/><ref id="gold"/>
	</shape>
	<emitter type="point"><point name="position" x="2" y="3" z="4"/><spectrum name="intensity" value="40"/></emitter>
	<emitter type="sunsky"><float name="turbidity" value="3"/><float name="sunRadiusScale" value="2"/></emitter>
</scene>
"""


def _module(name: str = "import_scenes"):
    spec = importlib.util.spec_from_file_location(name, SCRIPT.with_name(name + ".py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _cli(*args):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=60)


@pytest.fixture
def source(tmp_path, mi):
    """A dppm-scenes-like checkout whose `box` folder holds the 0.6 snippet, a texture, and a file nobody uses."""
    folder = tmp_path / "src" / "scenes" / "box"
    (folder / "textures").mkdir(parents=True)
    (folder / "scene.xml").write_text(SCENE_06)
    texture = np.tile(np.array([[0.2], [0.8]], dtype=np.float32), (2, 2))[:, :, None].repeat(3, axis=2)
    mi.Bitmap(texture).write(str(folder / "textures" / "tiles.exr"))
    (folder / "unused.obj").write_text("# not referenced by the scene\n")
    variant = SCENE_06.replace("textures/tiles.exr", "./textures/elsewhere.jpg")
    (folder / "box_rand_scene0.xml").write_text(variant)
    return tmp_path / "src"


def _one_error_line(result, *words):
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "Traceback" not in result.stderr
    for word in words:
        assert word in lines[0]


def test_snake_case_follows_mitsubas_own_upgrade():
    snake = _module("mitsuba06").snake_case  # the translation rules, beside the script
    assert [snake(n) for n in ("toWorld", "intIOR", "extEta", "fovAxis", "sampleCount", "radius")] == \
        ["to_world", "int_ior", "ext_eta", "fov_axis", "sample_count", "radius"]


def test_each_translation_is_applied_and_has_a_readme_line(source, tmp_path):
    folder = _module().import_scene(source, tmp_path / "out", "box", variants=True)
    root = ET.parse(folder / "scene.xml").getroot()
    assert root.get("version") == "3.0.0" and root.find("default") is None
    integrator = root.find("integrator")
    assert integrator.get("type") == "path"
    assert [(c.get("name"), c.get("value")) for c in integrator] == [("max_depth", "5")]
    sensor = root.find("sensor")
    assert sensor.find("string[@name='fov_axis']").get("value") == "smaller"
    assert sensor.find("sampler").get("type") == "independent"
    assert sensor.find("sampler/integer[@name='sample_count']").get("value") == "4"
    film = sensor.find("film")
    assert film.get("type") == "hdrfilm" and {c.get("name") for c in film} == {"width", "height"}
    glass = root.find("bsdf[@id='glass']")
    assert {c.get("name") for c in glass} == {"int_ior", "ext_ior"}
    lacquer = root.find("bsdf[@id='lacquer']")
    assert lacquer.get("type") == "blendbsdf"
    assert [b.get("type") for b in lacquer.findall("bsdf")] == ["diffuse", "roughconductor"]
    assert float(lacquer.find("float[@name='weight']").get("value")) == pytest.approx(0.25)
    assert root.find("bsdf[@id='gold']/float[@name='ext_eta']") is None
    assert root.find("bsdf[@id='tiles']/texture/string[@name='filter_type']").get("value") == "bilinear"
    sunsky = root.find("emitter[@type='sunsky']")
    assert float(sunsky.find("float[@name='sun_aperture']").get("value")) == pytest.approx(2 * 0.5338, rel=1e-3)
    assert sunsky.find("transform[@name='to_world']/rotate").get("angle") == "-90"

    readme = (folder / "README.md").read_text()
    for line in ("integrator `$method` (default `sppm`) replaced by `path`", "dropped its `photonCount`",
                 "renamed `intIOR` to `int_ior`", "renamed `extIOR` to `ext_ior`", "renamed `toWorld` to `to_world`",
                 "dropped `alpha` on the smooth dielectric", "bsdf `ward` `lacquer` became `blendbsdf`",
                 "dropped `ext_eta` = 1 on roughconductor", "`filter_type` `trilinear` became `bilinear`",
                 "`sun_radius_scale` 2 became `sun_aperture`", "film `ldrfilm` became `hdrfilm`",
                 "sampler `ldsampler` became `independent`", "dropped film parameter `banner`",
                 "substituted `$spp` by its default `4`", "scene `version` 0.6.0 -> 3.0.0"):
        assert any(row.startswith("- ") and line in row for row in readme.splitlines()), line
    assert "Licence:" in readme and "Author:" in readme
    # only what the scene references travels; the variant's missing texture becomes a constant, said so
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()) == \
        ["README.md", "rand_scene0.xml", "scene.xml", "textures/tiles.exr"]
    assert "texture `textures/elsewhere.jpg` is not in the scene's folder: replaced by a uniform 0.5" in readme
    variant = ET.parse(folder / "rand_scene0.xml").getroot()
    assert variant.find("bsdf[@id='tiles']/texture").attrib == {"name": "reflectance", "type": "uniform"}


def test_the_imported_scene_loads_and_renders(source, tmp_path, mi):
    from gmcpt.render.scene import load_scene

    folder = _module().import_scene(source, tmp_path / "out", "box", variants=True)
    for name in ("scene.xml", "rand_scene0.xml"):
        scene = load_scene(folder / name, (8, 6))
        image = np.array(mi.render(scene, spp=2))
        assert image.shape == (6, 8, 3)
        assert np.isfinite(image).all() and image.mean() > 0


def test_held_out_scenes_are_refused(tmp_path):
    for name in ("classroom", "staircase"):
        result = _cli("--source", tmp_path, "--out", tmp_path / "out", "sponza", name)
        _one_error_line(result, name, "held out")
        assert not (tmp_path / "out").exists()


def test_a_missing_source_or_scene_folder_is_one_line(tmp_path, source):
    _one_error_line(_cli("--source", tmp_path / "nowhere", "--out", tmp_path / "out", "box"), "nowhere")
    _one_error_line(_cli("--source", source, "--out", tmp_path / "out", "sponza"), "sponza")
    _one_error_line(_cli("--source", source, "--out", tmp_path / "out", "kitchen"), "unknown scene")
    assert not (tmp_path / "out").exists()


def test_a_failure_leaves_nothing_behind(tmp_path, source):
    scene = source / "scenes" / "box" / "scene.xml"
    scene.write_text(scene.read_text().replace("</scene>", '<shape type="obj"><string name="filename" '
                                                            'value="models/gone.obj"/></shape></scene>'))
    out = tmp_path / "out"
    out.mkdir()
    _one_error_line(_cli("--source", source, "--out", out, "box"), "models/gone.obj")
    assert list(out.iterdir()) == []
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    _one_error_line(_cli("--source", source, "--out", blocker / "out", "box"), "cannot write")


def test_the_cli_writes_the_scene_and_prints_its_path(tmp_path, source):
    result = _cli("--source", source, "--out", tmp_path / "out", "box")
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == str(tmp_path / "out" / "box" / "scene.xml")
    assert not (tmp_path / "out" / "box" / "rand_scene0.xml").exists()  # variants only when asked
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["box"]


#: 0.6 constructs of the training-only scenes (bathroom, bathroom2): each has a rule of its own
EXTRAS_06 = """
	<bsdf type="diffuse" id="painted"><rgb name="diffuseReflectance" value="#ff8000"/></bsdf>
	<bsdf type="diffuse" id="linear"><texture name="reflectance" type="bitmap">
		<string name="filename" value="textures/tiles.exr"/><float name="gamma" value="1"/></texture></bsdf>
	<bsdf type="diffuse" id="curved"><texture name="reflectance" type="bitmap">
		<string name="filename" value="textures/tiles.exr"/><float name="gamma" value="3.2"/></texture></bsdf>
	<bsdf type="roughdielectric" id="frosted"><string name="distribution" value="phong"/>
		<float name="alpha" value="0.2"/></bsdf>
	<bsdf type="conductor" id="chrome"><string name="distribution" value="phong"/></bsdf>
	<shape type="obj"><string name="filename" value="models/gone.obj"/><ref id="chrome"/></shape>
	<shape type="sphere"><point name="center" x="0" y="1.3" z="1"/><float name="radius" value="0.2"/>
		<ref id="frosted"/></shape>
</scene>
"""


def test_training_scene_rules_and_dropped_missing_shapes(source, tmp_path, mi):
    from gmcpt.render.scene import load_scene

    scene = source / "scenes" / "box" / "scene.xml"
    scene.write_text(scene.read_text().replace("</scene>", EXTRAS_06))
    module = _module()
    with pytest.raises(module.SceneImportError, match="models/gone.obj"):  # missing files fail unless asked
        module.import_scene(source, tmp_path / "out", "box", variants=False)
    folder = module.import_scene(source, tmp_path / "out", "box", variants=False, drop_missing=True)
    root = ET.parse(folder / "scene.xml").getroot()
    assert root.find("bsdf[@id='painted']/rgb").get("value") == "1 0.501961 0"
    linear = root.find("bsdf[@id='linear']/texture")
    assert linear.find("boolean[@name='raw']").get("value") == "true" and linear.find("float") is None
    assert root.find("bsdf[@id='curved']/texture/float") is None
    assert root.find("bsdf[@id='frosted']/string[@name='distribution']").get("value") == "beckmann"
    assert root.find("bsdf[@id='chrome']/string") is None
    assert not any(s.find("string[@name='filename']") is not None and "gone" in s.find("string").get("value")
                   for s in root.iter("shape"))
    readme = (folder / "README.md").read_text()
    for line in ("`<rgb>` hexadecimal colour became three floats", "bitmap `gamma` 1 became `raw` true",
                 "bitmap `gamma` 3.2 dropped", "roughdielectric distribution `phong` became `beckmann`",
                 "dropped `distribution` on the smooth conductor",
                 "shape file `models/gone.obj` is missing from the source snapshot: the shape was dropped"):
        assert any(row.startswith("- ") and line in row for row in readme.splitlines()), line
    image = np.array(mi.render(load_scene(folder / "scene.xml", (8, 6)), spp=2))
    assert np.isfinite(image).all() and image.mean() > 0


def test_training_scenes_have_metadata_and_are_never_evaluation_ones():
    module = _module()
    for name in module.TRAINING_NAMES:
        info = module.SCENES[name]
        assert info["licence"] and info["author"] and info["use"].startswith("Training only")
        assert name not in module.DEFAULT_NAMES and name not in module.HELD_OUT
