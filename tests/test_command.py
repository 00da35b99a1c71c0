"""The front door: ``gmcpt`` and its subcommands, their help, the README's tables of them, ``gmcpt reference``."""
import argparse
import importlib
import re
import subprocess
import sys

import numpy as np
import pytest

from conftest import CORNELL, ROOT

README = ROOT / "README.md"


def gmcpt(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "gmcpt", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


def parsers() -> dict[str, argparse.ArgumentParser]:
    from gmcpt.cli import SUBCOMMANDS

    return {name: importlib.import_module(module).build_parser() for name, (module, _) in SUBCOMMANDS.items()}


def test_help_lists_every_subcommand_in_one_line_each():
    from gmcpt.cli import SUBCOMMANDS

    result = gmcpt("--help")
    assert result.returncode == 0 and result.stdout.startswith("usage: gmcpt SUBCOMMAND")
    listed = re.findall(r"(?m)^  (\w+) +\S", result.stdout)
    assert listed == list(SUBCOMMANDS)


@pytest.mark.parametrize("argv", [["frobnicate"], ["frobnicate", "--out", "x.exr"]])
def test_an_unknown_subcommand_is_one_line_naming_it(argv):
    result = gmcpt(*argv)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error: unknown subcommand 'frobnicate'")
    assert "render, reference, compare, batch, regress, eval, dataset, train, methods" in result.stderr


@pytest.mark.parametrize("name", ["render", "reference", "compare", "batch", "regress", "eval", "dataset", "train",
                                  "methods"])
def test_every_subcommand_reads_gmcpt_name_in_plain_text_and_says_its_defaults(name):
    parser = parsers()[name]
    assert parser.format_usage().startswith(f"usage: gmcpt {name} ")
    assert "``" not in parser.format_help() and ":mod:" not in parser.format_help()
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        assert action.help, f"{name} {action.dest}: no help"
        flag = action.nargs == 0 or not action.option_strings or action.required
        shown = "default" in parser._get_formatter()._get_help_string(action)
        assert flag or shown, f"{name} {action.option_strings}: no default shown"


def test_a_bad_option_of_every_subcommand_is_one_line(capsys):
    from gmcpt.cli import main

    for name in parsers():
        assert main([name, "--no-such-option"]) == 2, name
        error = capsys.readouterr().err
        assert error.count("\n") == 1 and error.startswith("error: "), (name, error)


def _readme_tables() -> dict[str, list[str]]:
    """``<!-- options: NAME -->`` -> the rows of the table under it."""
    text = README.read_text()
    tables = {}
    for match in re.finditer(r"<!-- options: (\w+) -->\n((?:\|.*\n)+)", text):
        tables[match[1]] = match[2].splitlines()[2:]
    return tables


def _named(row: str) -> list[str]:
    """The options a table row names: ``| `--ray ADDRESS`, `--gpus G` | ...`` -> ['--ray', '--gpus']."""
    return [name.split()[0] for name in re.findall(r"`(-[^`]+)`", row.split("|")[1])]


def test_readme_option_tables_match_the_parsers():
    from gmcpt.cli.render import add_render_options

    tables = _readme_tables()
    assert set(tables) == {"render", "batch"}
    shared = {action.dest for action in add_render_options(argparse.ArgumentParser())._actions}
    for name, rows in tables.items():
        parser = parsers()[name]
        actions = [action for action in parser._actions if action.option_strings and action.dest != "help"
                   and (name == "render" or action.dest not in shared)]
        by_name = {option: row for row in rows for option in _named(row)}
        for action in actions:
            named = [option for option in action.option_strings if option in by_name]
            assert named, f"README's {name} table lacks {action.option_strings}"
            row = by_name[named[0]].replace("`", "")
            if action.default not in (None, False, []):
                assert str(action.default) in row, (action.option_strings, action.default, row)
            said = re.search(r"\(default: (?:the )?([^)]*)\)", action.help)
            if said and said[1] != "none" and len(_named(by_name[named[0]])) == 1:
                assert said[1] in row, (action.option_strings, said[1], row)
        known = {option for action in actions for option in action.option_strings}
        assert set(by_name) <= known, f"README's {name} table names options {name} lacks: {set(by_name) - known}"


def test_readme_lists_the_subcommands():
    from gmcpt.cli import SUBCOMMANDS

    table = re.search(r"\| subcommand \|.*\n\|---.*\n((?:\|.*\n)+)", README.read_text())[1]
    listed = [name for row in table.splitlines() for name in re.findall(r"`(\w+)`", row.split("|")[1])]
    assert listed == list(SUBCOMMANDS)


def test_a_scene_first_still_means_render(tmp_path):
    from gmcpt.cli import subcommand

    assert subcommand([str(CORNELL), "--out", "x.exr"])[0] == "render"
    assert subcommand(["--rate", "0.3", str(CORNELL)])[0] == "render"
    assert subcommand(["batch", str(CORNELL)]) == ("batch", [str(CORNELL)])
    assert subcommand(["cornell"])[0] is None
    scene = tmp_path / "shot.json"  # a scene file of any name
    scene.write_text("<scene/>")
    assert subcommand([str(scene), "--out", "x.exr"])[0] == "render"


def test_methods_lists_every_method_and_placement():
    from gmcpt.completion import methods
    from gmcpt.sampling.masks import PATTERNS

    result = gmcpt("methods")
    assert result.returncode == 0
    assert re.findall(r"(?m)^  (\w+) ", result.stdout) == methods() + list(PATTERNS)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("reference") / "made" / "ref.exr"
    result = gmcpt("reference", CORNELL, "--res", "24", "16", "--spp", "8", "--pass-spp", "2", "--out", out)
    assert result.returncode == 0, result.stderr
    return out, result


def test_reference_renders_in_passes_with_the_time_left(mi, reference):
    from gmcpt.evaluation.reference import render_full
    from gmcpt.io.exr import read_rgb_exr
    from gmcpt.cli.reference import DEFAULT_SEED
    from gmcpt.render.scene import load_scene

    out, result = reference
    assert "24x16 px, 8 spp in 4 passes" in result.stderr and "reference 4/4" in result.stderr
    assert re.search(r"reference 1/4 pass.*left\)", result.stderr)
    assert [p.name for p in out.parent.iterdir()] == ["ref.exr"]  # its folder made, no temporary left
    expected = render_full(load_scene(CORNELL, (24, 16)), 8, DEFAULT_SEED, 2)
    assert np.array_equal(read_rgb_exr(out), expected)


def test_a_reference_serves_render(reference, tmp_path):
    import json

    out, _ = reference
    result = gmcpt(CORNELL, "--res", "24", "16", "--spp", "2", "--reference", out, "--out", tmp_path / "r.exr", "-q")
    assert result.returncode == 0, result.stderr
    metrics = json.loads((tmp_path / "r.json").read_text())["metrics"]
    assert 5 < metrics["psnr"] < 60 and metrics["mse"] > 0 and metrics["ssim"] < 1


@pytest.mark.parametrize("args, message", [(["--spp", "0"], "--spp must be >= 1"),
                                           (["--res", "0", "4"], "--res must be positive"),
                                           (["-D", "frame"], "-D expects NAME=VALUE")])
def test_reference_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    result = gmcpt("reference", CORNELL, *args, "--out", tmp_path / "ref.exr")
    assert result.returncode == 2 and result.stderr.count("\n") == 1 and message in result.stderr, result.stderr
    assert list(tmp_path.iterdir()) == []
