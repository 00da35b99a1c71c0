"""Writing and interruptions (issue 26, causes 9-12): a full disk, a failed rename, SIGTERM while writing,
Ctrl-C while starting; and the evaluation's refusals without the shared scenes beside the checkout.

A full disk and a failed rename are simulated in-process (the write or the rename raises as the
library does on a real full disk); the signals are sent to a real command-line process.
"""
import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import CORNELL, ROOT, synthetic_frame
from gmcpt.errors import GmcptError
from reliability_helpers import assert_one_line, previous_outputs, snapshot

TINY = [str(CORNELL), "--res", "16", "16", "--spp", "1", "--method", "interp", "-q"]
FULL = os.strerror(errno.ENOSPC)


def _main(capfd, *arguments):
    from gmcpt.cli import main

    capfd.readouterr()
    status = main([*TINY, *map(str, arguments)])
    return status, capfd.readouterr().err


def _exr_fails_as_on_a_full_disk(path, *args, **kwargs):
    """What OpenEXR does on a full disk: part of the file, then a RuntimeError naming the (temporary) file."""
    Path(path).write_bytes(b"half an EXR")
    raise RuntimeError(f'Failed to write pixel data to image file "{path}". {FULL}.')


def _json_fails_as_on_a_full_disk(self, text, *args, **kwargs):
    with open(self, "w") as handle:
        handle.write(text[:10])
    raise OSError(errno.ENOSPC, FULL, str(self))


# 9. a full disk
@pytest.mark.parametrize("failing", ["exr", "json"])
@pytest.mark.parametrize("earlier", [True, False], ids=["over a previous run", "new"])
def test_full_disk_is_one_line_and_leaves_the_outputs_as_they_were(mi, tmp_path, capfd, monkeypatch, failing, earlier):
    from gmcpt.io import outputs

    out = previous_outputs(tmp_path) if earlier else tmp_path / "out.exr"
    before = snapshot(tmp_path)
    if failing == "exr":
        monkeypatch.setattr(outputs, "write_exr", _exr_fails_as_on_a_full_disk)
    else:
        monkeypatch.setattr(Path, "write_text", _json_fails_as_on_a_full_disk)
    status, stderr = _main(capfd, "--out", out)
    line = assert_one_line(status, stderr, f"cannot write {out.with_suffix('.' + failing)}: {FULL}")
    assert snapshot(tmp_path) == before  # no partial, new or temporary file
    frame, image = synthetic_frame(16, 16)
    with pytest.raises(GmcptError) as error:
        outputs.write_outputs(out, frame, image, {"parameters": {}})
    assert str(error.value) == line and snapshot(tmp_path) == before


# 10. a rename that fails after others succeeded
def _failing_rename(monkeypatch, target: Path):
    """os.replace fails once, for the rename of a temporary over ``target`` (not for putting a file back)."""
    real, failed = os.replace, []

    def replace(source, destination, *args, **kwargs):
        if Path(destination) == target and Path(source).name.startswith(".") and not failed:
            failed.append(source)
            raise OSError(errno.EIO, os.strerror(errno.EIO), str(destination))
        return real(source, destination, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace)
    return failed


@pytest.mark.parametrize("failing", [".exr", ".png", ".json"])
@pytest.mark.parametrize("earlier", [True, False], ids=["over a previous run", "new"])
def test_failed_rename_leaves_no_mixed_set(tmp_path, monkeypatch, failing, earlier):
    from gmcpt.io.outputs import write_outputs

    out = previous_outputs(tmp_path) if earlier else tmp_path / "out.exr"
    before = snapshot(tmp_path)
    failed = _failing_rename(monkeypatch, out.with_suffix(failing))
    frame, image = synthetic_frame(16, 16)
    with pytest.raises(GmcptError, match=f"cannot write {out.with_suffix(failing)}: {os.strerror(errno.EIO)}"):
        write_outputs(out, frame, image, {"parameters": {}})
    assert failed and snapshot(tmp_path) == before  # all three as before (or none), no backup or temporary left


def test_failed_rename_from_the_command_line(mi, tmp_path, capfd, monkeypatch):
    out = previous_outputs(tmp_path)
    before = snapshot(tmp_path)
    _failing_rename(monkeypatch, out)  # the EXR: in the set's first rename or its last, others are replaced
    status, stderr = _main(capfd, "--out", out)
    assert_one_line(status, stderr, f"cannot write {out}: {os.strerror(errno.EIO)}")
    assert snapshot(tmp_path) == before


# 11. SIGTERM (and Ctrl-C) while the outputs are written
SLOW_WRITE = """
import sys, time
from pathlib import Path
from gmcpt.io import outputs
from gmcpt.cli import main

write_png = outputs.write_png

def slow(path, image):  # the PNG is written, the JSON not yet: the set is half done
    write_png(path, image)
    Path(sys.argv[1]).write_text("writing")
    time.sleep(120)

outputs.write_png = slow
sys.exit(main(sys.argv[2:]))
"""


def _signal_once_marked(script_text: str, folder: Path, out: Path, number: int) -> tuple[int, str]:
    """Run ``script_text`` (argv: a marker file, then the command line) on TINY; send signal ``number`` once
    the script has made the marker; (exit status, stderr)."""
    script, marker = folder / "script.py", folder / "marker"
    script.write_text(script_text)
    process = subprocess.Popen([sys.executable, str(script), str(marker), *TINY, "--out", str(out)], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "PYTHONPATH": str(ROOT)})
    deadline = time.monotonic() + 120
    while not marker.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert marker.exists(), process.communicate()[1]
    process.send_signal(number)
    _, stderr = process.communicate(timeout=60)
    return process.returncode, stderr


@pytest.mark.parametrize("number, status, message", [(signal.SIGTERM, 143, "terminated"),
                                                     (signal.SIGINT, 130, "interrupted")], ids=["SIGTERM", "SIGINT"])
def test_signal_while_writing_removes_the_temporaries(tmp_path, number, status, message):
    folder = tmp_path / "out"
    folder.mkdir()
    out = previous_outputs(folder)
    before = snapshot(folder)
    returncode, stderr = _signal_once_marked(SLOW_WRITE, tmp_path, out, number)
    assert_one_line(returncode, stderr, message, code=status)
    assert snapshot(folder) == before  # the previous run's outputs, and no hidden temporary


AFTER_WRITE = """
import sys, time
from pathlib import Path
from gmcpt.io import outputs
from gmcpt.cli import main

write_outputs = outputs.write_outputs

def then_wait(*args, **kwargs):  # the three files are in place; the command has not ended yet
    written = write_outputs(*args, **kwargs)
    Path(sys.argv[1]).write_text("written")
    time.sleep(3)
    return written

outputs.write_outputs = then_wait
sys.exit(main(sys.argv[2:]))
"""


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_once_the_outputs_are_complete_exits_0(tmp_path, number):
    out = tmp_path / "out" / "x.exr"
    returncode, stderr = _signal_once_marked(AFTER_WRITE, tmp_path, out, number)
    assert returncode == 0 and "error" not in stderr, stderr
    assert sorted(p.name for p in out.parent.iterdir()) == ["x.exr", "x.json", "x.png"]  # its folder made too


# 12. Ctrl-C while the command line starts
def _native_module_loading(pid: int) -> bool:
    try:
        return "drjit" in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


@pytest.mark.skipif(not Path("/proc/self/maps").is_file(), reason="watches /proc/PID/maps for the import of Dr.Jit")
@pytest.mark.parametrize("command", [["render_and_complete.py"], ["-m", "gmcpt"]], ids=["script", "-m gmcpt"])
def test_ctrl_c_during_start_up_is_one_line(tmp_path, command):
    """SIGINT once Dr.Jit's library is mapped, that is inside ``import gmcpt``: one line, exit 130."""
    process = subprocess.Popen([sys.executable, *command, *TINY, "--out", str(tmp_path / "out.exr")], cwd=ROOT,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not _native_module_loading(process.pid) and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.001)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=120)
    assert_one_line(process.returncode, stderr, "interrupted", code=130)
    assert stdout == "" and list(tmp_path.iterdir()) == []


# the evaluation without ../shared beside the checkout
@pytest.mark.parametrize("args, message", [(["--out", "README.md", "--no-readme"], "--out README.md is not a folder"),
                                           (["--scenes", "breakfast-room", "--procedural", "0", "--out", "README.md"],
                                            "no evaluation scene is available")])
def test_eval_refusals_without_the_shared_scenes(tmp_path, args, message):
    environment = {**os.environ, "PYTHONWARNINGS": "ignore", "GMCPT_SHARED_SCENES": str(tmp_path / "absent")}
    result = subprocess.run([sys.executable, "-m", "gmcpt", "eval", *args], capture_output=True, text=True, cwd=ROOT,
                            env=environment, timeout=300)
    assert_one_line(result.returncode, result.stderr, message)


def test_shared_scenes_folder_follows_the_environment(tmp_path):
    environment = {**os.environ, "GMCPT_SHARED_SCENES": str(tmp_path)}
    code = "from gmcpt.evaluation.scenes import BREAKFAST; print(BREAKFAST.path, BREAKFAST.available())"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=environment,
                            timeout=300)
    assert result.stdout.split() == [str(tmp_path / "breakfast-room" / "scene.xml"), "False"], result.stderr
