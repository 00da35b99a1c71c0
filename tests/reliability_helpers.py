"""What the reliability tests share: running the command line as a user would, and what a refusal must look like."""
import os
import subprocess
import sys

from conftest import ROOT


def run_plain(*args, cwd=ROOT, env=None, timeout=120):
    """The command line with the user's environment: Python warnings shown (no PYTHONWARNINGS=ignore)."""
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONWARNINGS"}
    environment["PYTHONPATH"] = str(ROOT)
    environment.update(env or {})
    return subprocess.run([sys.executable, str(ROOT / "render_and_complete.py"), *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, env=environment, timeout=timeout)


def assert_one_line(status: int, stderr: str, message: str, code: int = 2) -> str:
    """Exit ``code``, one ``error: ...`` line on stderr naming ``message``, no traceback, no internal error."""
    lines = stderr.strip().splitlines()
    assert status == code, stderr
    assert len(lines) == 1 and lines[0].startswith("error: "), stderr
    assert message in lines[0], stderr
    assert "Traceback" not in stderr and "internal error" not in stderr, stderr
    return lines[0].removeprefix("error: ")


def assert_refused(result, message: str) -> str:
    """A refusal of bad input by the command line (a CompletedProcess); the message after ``error: ``."""
    assert "Traceback" not in result.stdout
    return assert_one_line(result.returncode, result.stderr, message)


def snapshot(folder) -> dict:
    """Every file under ``folder`` (hidden ones too) and its bytes."""
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def previous_outputs(folder, name="out"):
    """OUT.exr, OUT.png, OUT.json of an earlier run (placeholder bytes); returns OUT.exr."""
    for suffix in (".exr", ".png", ".json"):
        (folder / (name + suffix)).write_bytes(b"previous run " + suffix.encode())
    return folder / f"{name}.exr"
