"""Procedural scene generator and dataset builder (gmcpt.dataset)."""
import json

import numpy as np
import pytest


def _summary(value):
    """A comparable, object-free summary of a scene description."""
    if isinstance(value, dict):
        return {k: _summary(v) for k, v in sorted(value.items())}
    if isinstance(value, (list, tuple)):
        return [_summary(v) for v in value]
    if isinstance(value, (int, float, str, bool)) or value is None:
        return value
    return type(value).__name__ + ":" + " ".join(str(value).split())[:200]


def _types(description, key="type"):
    found = set()

    def walk(node):
        if isinstance(node, dict):
            if key in node and isinstance(node[key], str):
                found.add(node[key])
            for child in node.values():
                walk(child)
        elif type(node).__name__ == "Mesh":
            found.add("mesh")
    walk(description)
    return found


def test_same_seed_same_scene_and_seeds_differ(mi):
    from gmcpt.dataset.scenes import scene_description

    a, b = _summary(scene_description(7, 32)), _summary(scene_description(7, 32))
    assert a == b
    assert _summary(scene_description(8, 32)) != a
    # exposure only scales the lights: the rest of the scene is unchanged
    assert _summary(scene_description(7, 32, exposure=3.0))["sensor"] == a["sensor"]


def test_generator_covers_required_variety(mi):
    from gmcpt.dataset.scenes import scene_description

    found = set()
    for seed in range(80):
        found |= _types(scene_description(seed, 16))
    needed = {"rectangle", "cube", "sphere", "cylinder", "mesh",                              # shapes
              "diffuse", "bitmap", "plastic", "roughplastic", "conductor", "roughconductor",    # materials
              "dielectric", "roughdielectric",
              "area", "point", "spot", "directional", "constant", "envmap"}                    # lights
    assert needed <= found, needed - found


def test_scenes_load_and_render(mi):
    from gmcpt.dataset.scenes import build_scene

    for seed in (0, 2_000_000):
        scene = build_scene(seed, 16)
        image = np.asarray(mi.render(scene, spp=4))
        assert image.shape[:2] == (16, 16) and np.isfinite(image).all()


@pytest.mark.parametrize("builder", ["torus", "cone", "pyramid", "prism", "vase", "blob"])
def test_meshes_are_closed_and_outward(builder):
    from gmcpt.dataset import meshes

    rng = np.random.default_rng(0)
    vertices, faces = getattr(meshes, builder)(rng) if builder in ("vase", "blob") else getattr(meshes, builder)()
    v = vertices.astype(np.float64)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    assert np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6 > 0  # positive signed volume: normals point out
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()  # closed, manifold


def test_splits_never_share_seeds():
    from gmcpt.dataset import SplitSpec, split_of

    seeds = {name: set(SplitSpec(name, 5000).seeds()) for name in ("train", "val", "test")}
    assert not seeds["train"] & seeds["val"] and not seeds["train"] & seeds["test"] and not seeds["val"] & seeds["test"]
    assert all(split_of(s) == name for name, group in seeds.items() for s in group)
    with pytest.raises(ValueError):
        SplitSpec("train", 2_000_000).seeds()


def test_a_dataset_of_a_removed_scene_layout_is_not_extended(tmp_path):
    from gmcpt.dataset import DatasetSpec, SplitSpec, build

    manifest = {**DatasetSpec().to_json(), "splits": {}, "layout": "interior"}
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match="built with the scene layout interior"):
        build(tmp_path, DatasetSpec(splits=(SplitSpec("train", 1, 16, 16),)), workers=0, say=lambda m: None)
    (tmp_path / "manifest.json").write_text(json.dumps({**manifest, "layout": "mixed"}))   # what every build was
    build(tmp_path, DatasetSpec(splits=(SplitSpec("train", 0, 16, 16),)), workers=0, say=lambda m: None)


def test_build_resume_and_product_identical_inputs(mi, tmp_path):
    from gmcpt.dataset import DatasetSpec, SplitSpec, build, example_path, list_examples, load_example
    from gmcpt.dataset.build import is_complete
    from gmcpt.dataset.scenes import build_scene
    from gmcpt.sampling.strategies import RenderSettings, render_sparse_frame

    spec = DatasetSpec(splits=(SplitSpec("train", 1, 16, 16),), pass_spp=8)
    summary = build(tmp_path, spec, workers=0, say=lambda m: None)
    assert summary["rendered"] == 1
    assert build(tmp_path, spec, workers=0, say=lambda m: None)["rendered"] == 0  # resumes: nothing left
    path = example_path(tmp_path, "train", 0)
    assert list_examples(tmp_path, "train") == [path]
    example = load_example(path)
    meta = example["meta"]
    assert meta["version"] == spec.version and meta["seed"] == 0 and meta["split"] == "train"
    assert 0.15 <= meta["rate"] <= 0.5 and abs(example["mask"].mean() - meta["rate"]) < 0.01
    assert example["reference"].shape == (16, 16, 3) and np.isfinite(example["reference"]).all()
    assert example["full_radiance"].shape == (16, 16, 3)
    # the stored inputs are exactly what the product renders for that scene, rate and seed
    scene = build_scene(0, 16, meta["exposure"], spec.spp)
    frame, _ = render_sparse_frame(scene, scene.integrator(), settings=RenderSettings(rate=1.0, spp=16, seed=0))
    settings = RenderSettings(rate=meta["rate"], pattern="random", spp=16, seed=0)  # the dataset's mask
    sparse, _ = render_sparse_frame(scene, scene.integrator(), settings=settings)
    np.testing.assert_array_equal(sparse.mask, example["mask"])
    np.testing.assert_array_equal(sparse.radiance, example["radiance"])
    np.testing.assert_array_equal(frame.radiance, example["full_radiance"])
    for name in ("albedo", "normal", "depth", "visibility"):
        np.testing.assert_array_equal(getattr(frame, name), example[name])
    assert (example["radiance"][~example["mask"]] == 0).all()
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert set(manifest["splits"]) == {"train"}
    # a truncated file counts as missing, so the next build renders it again
    assert is_complete(path)
    path.write_bytes(path.read_bytes()[:100])
    assert not is_complete(path)


def test_cli_rejects_bad_arguments(tmp_path, capsys):
    from gmcpt.cli.dataset import main

    assert main(["--out", str(tmp_path / "d"), "--rate", "0.6", "0.2"]) == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize("old_version", [1, 2])
def test_older_files_are_upgraded_to_the_features_of_a_fresh_build(mi, tmp_path, old_version):
    from dataclasses import replace

    from gmcpt.dataset import DATASET_VERSION, DatasetSpec, SplitSpec, build, example_path, load_example
    from gmcpt.dataset.build import FEATURE_KEYS, save_example
    from gmcpt.render.kernels import DEFAULT_FEATURE_SPP

    spec = DatasetSpec(splits=(SplitSpec("train", 1, 16, 16),), pass_spp=8)
    assert spec.feature_spp == DEFAULT_FEATURE_SPP and spec.version == DATASET_VERSION == 3
    old, fresh = tmp_path / "old", tmp_path / "fresh"
    build(old, replace(spec, version=old_version, feature_spp=1), workers=0, say=lambda m: None)
    path = example_path(old, "train", 0)
    stale = load_example(path)
    del stale["coverage"]  # versions 1 and 2 had no coverage buffer
    meta = stale.pop("meta")
    save_example(path, {"arrays": stale, "meta": meta})
    assert load_example(path)["meta"]["version"] == old_version
    assert build(old, spec, workers=0, say=lambda m: None)["rendered"] == 1  # upgraded in place
    upgraded = load_example(path)
    build(fresh, spec, workers=0, say=lambda m: None)
    rebuilt = load_example(example_path(fresh, "train", 0))
    assert upgraded["meta"]["version"] == 3 and upgraded["meta"]["feature_spp"] == DEFAULT_FEATURE_SPP
    assert set(upgraded) == set(rebuilt)
    for key, value in rebuilt.items():
        if key != "meta":
            np.testing.assert_array_equal(upgraded[key], value, err_msg=key)
    assert any(not np.array_equal(stale[key], upgraded[key]) for key in FEATURE_KEYS if key in stale)
    assert json.loads((old / "manifest.json").read_text())["version"] == 3


@pytest.mark.slow  # 30 s, most of it Ray starting: the cluster path runs in make test-slow
def test_dataset_on_ray_writes_the_bits_of_a_one_process_build(tmp_path):
    """``--ray local`` renders each scene as a task: the arrays are those of the build in one process,
    which never imports Ray."""
    import subprocess
    import sys

    from conftest import ROOT
    from gmcpt.dataset import list_examples, load_example

    pytest.importorskip("ray")
    options = ["--train", "2", "--val", "0", "--res", "16", "--ref-spp", "8", "--spp", "4", "-q"]
    code = ("import sys; from gmcpt.cli import main; status = main(sys.argv[1:]); "
            "print('ray imported' if 'ray' in sys.modules else 'no ray'); sys.exit(status)")
    runs = {}
    for name, extra in (("one", ["--workers", "0"]), ("ray", ["--ray", "local"])):
        runs[name] = subprocess.run([sys.executable, "-c", code, "dataset", "--out", str(tmp_path / name),
                                     *options, *extra], capture_output=True, text=True, cwd=ROOT, timeout=600)
        assert runs[name].returncode == 0, runs[name].stderr
    assert "no ray" in runs["one"].stdout and runs["one"].stderr == ""
    one, ray = list_examples(tmp_path / "one", "train"), list_examples(tmp_path / "ray", "train")
    assert [p.name for p in one] == [p.name for p in ray] == ["0000000.npz", "0000001.npz"]
    for a, b in zip(map(load_example, one), map(load_example, ray)):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a if k != "meta")
        assert {k: v for k, v in a["meta"].items() if k != "seconds"} == \
            {k: v for k, v in b["meta"].items() if k != "seconds"}


@pytest.fixture
def real_root(tmp_path):
    """Two 'real' scene folders as scripts/import_scenes.py lays them out (the bundled Cornell box, twice)."""
    import shutil

    from conftest import ROOT

    root = tmp_path / "scenes"
    for folder in ("room-a", "room-b"):
        (root / folder).mkdir(parents=True)
        shutil.copy(ROOT / "scenes" / "cornell-box" / "scene.xml", root / folder / "scene.xml")
    shutil.copy(ROOT / "scenes" / "cornell-box" / "scene.xml", root / "room-a" / "rand_scene0.xml")
    return root


def test_real_scene_files_refuse_held_out_and_evaluation_scenes(tmp_path, real_root):
    from gmcpt.dataset.real import real_scene_files
    from gmcpt.errors import GmcptError
    from gmcpt.evaluation.scenes import evaluation_folder_names

    assert real_scene_files(real_root) == ("room-a/scene.xml", "room-a/rand_scene0.xml", "room-b/scene.xml")
    for bad, words in ((tmp_path / "nowhere", "not found"), (tmp_path, "no scene files")):
        with pytest.raises(GmcptError, match=words):
            real_scene_files(bad)
    for name in ("classroom", "staircase", "living-room", "sponza", "breakfast-room"):
        (real_root / name).mkdir()
        (real_root / name / "scene.xml").write_text("<scene/>")
        with pytest.raises(GmcptError, match=f"holds {name}: held-out and evaluation scenes are never trained on"):
            real_scene_files(real_root, evaluation_folder_names())
        (real_root / name / "scene.xml").unlink()
        (real_root / name).rmdir()


def test_real_views_are_seeded_and_in_range():
    from gmcpt.dataset.real import PITCH, YAW, ZOOM, draw_view

    files = ("a/scene.xml", "a/rand_scene0.xml", "b/scene.xml")
    views = [draw_view(seed, files, 16, (0.4, 1.2)) for seed in range(200)]
    assert views[7] == draw_view(7, files, 16, (0.4, 1.2))
    assert {v.file for v in views} == set(files)
    for view in views:
        assert abs(view.yaw) <= YAW and abs(view.pitch) <= PITCH and 16 <= view.side <= 16 * ZOOM
        assert all(0 <= o <= view.side - 16 for o in view.offset) and 0.4 <= view.target <= 1.2
    assert len({v.side for v in views}) > 5 and len({v.offset for v in views}) > 50


def test_real_build_is_a_crop_of_the_view_scaled_to_its_target(mi, tmp_path, real_root):
    from gmcpt.dataset import DatasetSpec, SplitSpec, build, list_examples, load_example
    import dataclasses

    from gmcpt.dataset.real import draw_view, real_scene_files
    from gmcpt.render.kernels import render_features
    from gmcpt.render.scene import load_scene

    files = real_scene_files(real_root)
    spec = DatasetSpec(splits=(SplitSpec("train", 2, 16, 16),), pass_spp=8, layout="real",
                       real_root=str(real_root), real_files=files)
    build(tmp_path / "a", spec, workers=0, say=lambda m: None)
    build(tmp_path / "b", spec, workers=0, say=lambda m: None)
    for path in list_examples(tmp_path / "a", "train"):
        example, again = load_example(path), load_example(tmp_path / "b" / "train" / path.name)
        for key in ("reference", "radiance", "full_radiance", "variance", "albedo", "depth"):
            np.testing.assert_array_equal(example[key], again[key])  # a pure function of the seed
        meta, view = example["meta"], draw_view(example["meta"]["seed"], files, 16, spec.exposure_range)
        assert (meta["scene"], meta["film_side"], tuple(meta["crop_offset"])) == (view.file, view.side, view.offset)
        assert example["reference"].shape == example["albedo"].shape == (16, 16, 3)
        # the light scale puts the reference's 95th luminance percentile at the view's target
        assert np.percentile(example["reference"].mean(-1), 95) == pytest.approx(view.target, rel=1e-4)
        # the crop is the view's window: the same turned camera, uncropped, holds it at the offset
        whole = dataclasses.replace(view, offset=(0, 0))
        scene = load_scene(real_root / view.file, (view.side, view.side), edit=whole.edit(view.side))
        albedo = render_features(scene, scene.sensors()[0], 16, 0)["albedo"]
        x, y = view.offset
        assert np.abs(albedo[y:y + 16, x:x + 16] - example["albedo"]).mean() < 0.03
        assert np.abs(albedo[y:y + 16, x:x + 16][:, ::-1] - example["albedo"]).mean() > 0.03 or view.yaw == 0
    with pytest.raises(ValueError, match="built with the scene layout real; this build renders mixed"):
        build(tmp_path / "a", DatasetSpec(splits=(SplitSpec("train", 1, 16, 16),)), workers=0, say=lambda m: None)


def test_cli_real_bad_values_are_one_line(tmp_path, capsys, real_root):
    from gmcpt.cli.dataset import main

    for argv, words in ((["--real", str(tmp_path / "none")], "real scene folder not found"),
                        (["--real", str(real_root), "--test", "2"], "--real builds train and val splits only")):
        assert main(["--out", str(tmp_path / "d"), *argv]) == 2
        err = capsys.readouterr().err
        assert err.startswith("error: ") and words in err and err.count("\n") == 1
    assert not (tmp_path / "d").exists()
