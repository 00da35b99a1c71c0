"""What a batch's frames leave behind, read by every way of running them (:mod:`gmcpt.cli.batch` in one process or on
Ray, :mod:`gmcpt.cli.sequence_ray`'s chunks): whether a frame's files are there and were made for the same request, so
that a stopped or retried batch skips them; and the test hook that loses a worker once."""
from __future__ import annotations

import json
import os

#: Test hook: the first task that creates this file (a path) kills its own process, once per batch.
CRASH_ONCE = "GMCPT_TEST_CRASH_ONCE"


def finished_record(job: dict) -> dict | None:
    """The JSON record of ``job``'s frame if its three files are there and match the request, else None.

    The EXR's header must hold the record's parameters: a set mixed from two runs does not pass.
    """
    import OpenEXR

    from ..io.outputs import sidecar_paths

    exr, png, record_path = sidecar_paths(job["out"])
    try:
        record = json.loads(record_path.read_text())
        if record.get("batch", {}).get("key") != job["key"] or png.stat().st_size == 0:
            return None
        with OpenEXR.File(str(exr), header_only=True) as file:
            stored = file.header().get("gmcpt")
    except Exception:  # missing, unreadable or foreign files: render again
        return None
    return record if stored == json.dumps(record.get("parameters", {})) else None


def crash_once() -> None:
    """Kill this process the first time any task of the batch gets here (``$GMCPT_TEST_CRASH_ONCE``: the marker
    file that says it happened), as a lost worker would be."""
    marker = os.environ.get(CRASH_ONCE)
    if marker:
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return
        os._exit(70)
