"""The small frictions of issue 48 ("Why" 6), each one clear line: the default crop on a small dataset, the
dataset's ``--res W H``, ``--tile``'s minimum in its help, a folder given as the scene, a missing ``--weights`` file.
"""
import numpy as np
import pytest

from conftest import ROOT, STILL_LIFE
from gan_helpers import tiny_dataset
from gmcpt.errors import GmcptError
from reliability_helpers import assert_one_line, assert_refused, run_plain, snapshot

TINY = ["--res", "16", "16", "--spp", "1", "--method", "interp", "-q"]


def _main(capfd, *arguments) -> tuple[int, str]:
    """``gmcpt ARGUMENTS`` in this process: (exit status, stderr)."""
    from gmcpt.cli import main

    capfd.readouterr()
    status = main([str(argument) for argument in arguments])
    return status, capfd.readouterr().err


# gmcpt train with the default crop (64) on a smaller dataset
def test_train_crop_larger_than_the_dataset_is_one_line(tmp_path, capfd):
    tiny_dataset(tmp_path / "data", count=1, size=32)
    status, stderr = _main(capfd, "train", "--config", "cpu", "--dataset", tmp_path / "data", "--out", tmp_path / "run",
                           "--set", "train.max_train_scenes=1", "-q")
    line = assert_one_line(status, stderr, "the training crops are 64 px")
    assert line.endswith("is 32x32: build the dataset at --res 64 or more, or train with --set train.crop=32")
    assert "high <= 0" not in stderr


def test_a_crop_that_fits_is_drawn(tmp_path):
    from gmcpt.dataset import list_examples
    from gmcpt.gan.data import PatchSampler

    tiny_dataset(tmp_path, count=1, size=32)
    batch = PatchSampler(list_examples(tmp_path, "train"), crop=32).batch(np.random.default_rng(0), 2, False)
    assert batch.target.shape == (2, 3, 32, 32)


# dataset --res: one number, or W H as every other --res
@pytest.mark.parametrize("res", [["32"], ["32", "32"]], ids=["N", "W H"])
def test_dataset_res_takes_one_number_or_w_h(res):
    from gmcpt.cli.dataset import build_parser, spec_from_args

    spec = spec_from_args(build_parser().parse_args(["--out", "x", "--res", *res, "--test", "1"]))
    assert [(split.name, split.resolution) for split in spec.splits] == [("val", 32), ("train", 32), ("test", 256)]


@pytest.mark.parametrize("res", [["32", "16"], ["32", "32", "32"]])
def test_dataset_res_of_a_rectangle_is_one_line(tmp_path, capfd, res):
    status, stderr = _main(capfd, "dataset", "--out", tmp_path / "data", "--res", *res)
    assert_one_line(status, stderr, f"--res takes N, or W H with W = H (the dataset's scenes are square), got "
                    f"{' '.join(res)}")
    assert list(tmp_path.iterdir()) == []


# --tile: its minimum in the help
@pytest.mark.parametrize("command", ["render", "batch"])
def test_tile_help_says_its_minimum(command, capsys):
    import importlib

    from gmcpt.completion.tiles import MIN_TILE, check_tile

    module = importlib.import_module({"render": "gmcpt.cli.render", "batch": "gmcpt.cli.batch"}[command])
    assert f"N >= {MIN_TILE}; 0: whole" in " ".join(module.build_parser().format_help().split())
    with pytest.raises(GmcptError, match=f"at least {MIN_TILE} pixels, got {MIN_TILE - 1}"):
        check_tile(MIN_TILE - 1)


# a folder given as the scene
@pytest.mark.parametrize("command", [[], ["render"], ["batch"], ["reference"]], ids=["gmcpt", "render", "batch",
                                                                                       "reference"])
def test_a_folder_as_the_scene_says_so(mi, tmp_path, capfd, command):
    folder = STILL_LIFE.parent.relative_to(ROOT)
    out = tmp_path / ("out" if command == ["batch"] else "out.exr")
    options = TINY[:5] if command == ["reference"] else TINY
    status, stderr = _main(capfd, *command, ROOT / folder, *options, "--out", out)
    assert_one_line(status, stderr, f"{ROOT / folder} is a folder, not a scene file; give the scene's XML file, "
                    f"e.g. {ROOT / folder / 'scene.xml'}")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_without_a_scene_file_says_so(tmp_path):
    (tmp_path / "scenes").mkdir()
    before = snapshot(tmp_path)
    result = run_plain(tmp_path / "scenes", *TINY, "--out", tmp_path / "out.exr")
    line = assert_refused(result, f"{tmp_path / 'scenes'} is a folder, not a scene file")
    assert line.endswith("give the scene's XML file") and snapshot(tmp_path) == before


# --weights FILE.pt that is not there: retrain to that file, not into the package's folder
@pytest.mark.parametrize("given", ["nope.pt", "runs/nope.pt"])
def test_missing_weights_file_suggests_exporting_to_it(mi, tmp_path, capfd, given):
    status, stderr = _main(capfd, STILL_LIFE, *TINY[:-3], "--method", "gan", "-q", "--weights", given,
                           "--out", tmp_path / "out.exr")
    line = assert_one_line(status, stderr, f"GAN weights not found: {given} (the shipped ones: gan-cpu")
    assert f"--export {given}`" in line and "--export nope`" not in line
    assert list(tmp_path.iterdir()) == []


def test_missing_shipped_name_suggests_its_name():
    from gmcpt.gan.names import WEIGHTS_DIR
    from gmcpt.gan.weights import load_generator

    with pytest.raises(GmcptError, match=f"not found: {WEIGHTS_DIR / 'nope.pt'} .*--export nope`"):
        load_generator("nope")
