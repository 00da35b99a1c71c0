"""Writing files so that no run leaves a partial, clobbered, mixed or hidden temporary file behind.

- :func:`write_together`: every file of a set (the EXR, PNG and JSON of a render) goes to a temporary
  beside its target; only when all are complete are they renamed over the targets, with SIGINT and
  SIGTERM deferred; if a rename fails, the files already replaced get their previous contents back
  (or are removed if they are new), so the outputs are all of one run or all of the run before.
- :func:`atomic_output`: the same for one file, as a context manager.
- A failed write (``OSError``, or a library's ``RuntimeError`` such as OpenEXR's on a full disk)
  is one :class:`GmcptError` line naming the target and the reason; temporaries are always removed.
- :func:`check_writable`, :func:`check_output` and :func:`check_not_inputs` refuse an output before any work;
  :func:`json_text` is strict JSON (a NaN or infinite number is written as ``null``);
  :func:`captured_output` keeps what a C library prints out of the terminal.
"""
from __future__ import annotations

import contextlib
import errno
import io
import json
import math
import os
import secrets
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterable, Sequence

from ..errors import GmcptError
from ..runtime.interrupts import held

#: failures a library reports in its message only (OpenEXR, Mitsuba's streams); named by their errno text
_REASONS = tuple(os.strerror(code) for code in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES,
                                                errno.EFBIG, errno.EIO))


def cache_folder(name: str) -> Path:
    """Folder ``name`` of gmcpt's disk cache: under ``$GMCPT_CACHE``, else ``~/.cache/gmcpt``."""
    return Path(os.environ.get("GMCPT_CACHE", Path.home() / ".cache" / "gmcpt")) / name


def _temporary(path: Path) -> str:
    """A new hidden file beside ``path``, with the mode a plain ``open`` would give."""
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    except OSError as error:
        raise _write_error(path, error) from None
    os.close(handle)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600
    return temporary


def _remove(path) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)


def _write_error(path: Path, error: BaseException, temporary: str | None = None) -> GmcptError:
    reason = getattr(error, "strerror", None) or " ".join(str(error).split()) or type(error).__name__
    if temporary:
        reason = reason.replace(temporary, str(path))
    reason = next((known for known in _REASONS if known in reason), reason)
    return GmcptError(f"cannot write {path}: {reason}")


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, committed: Callable[[], None] | None = None):
    """Yield a temporary path next to ``path``; rename it over ``path`` on success.

    An ``OSError`` while creating, writing or renaming (a read-only file system, a full disk)
    becomes a one-line :class:`GmcptError` naming ``path``; ``path`` itself is left as it was.
    ``committed`` runs once ``path`` is in place, before a signal deferred meanwhile arrives.
    """
    path = Path(path)
    temporary = None
    try:
        with held():  # a signal between making the temporary and knowing its name would leave it behind
            temporary = _temporary(path)
        yield temporary
        with held():
            os.replace(temporary, path)
            if committed is not None:
                committed()
    except OSError as error:
        raise _write_error(path, error, temporary) from None
    finally:
        if temporary is not None:
            _remove(temporary)


def _backup(path: Path) -> Path | None:
    """A hidden second name for ``path``'s current file (a hard link, else a copy); None if there is none."""
    if not os.path.lexists(path):
        return None
    backup = path.with_name(f".{path.name}.{secrets.token_hex(4)}.old")
    try:
        os.link(path, backup, follow_symlinks=False)
    except (OSError, NotImplementedError):
        shutil.copy2(path, backup, follow_symlinks=False)
    return backup


def _commit(pairs: Sequence[tuple[Path, str]]) -> None:
    """Rename each temporary over its target; on a failure put every target back as it was."""
    backups, done = {}, []
    try:
        for path, temporary in pairs:
            try:
                backups[path] = _backup(path)
                os.replace(temporary, path)
            except OSError as error:
                raise _write_error(path, error, temporary) from None
            done.append(path)
    except BaseException:
        for path in reversed(done):
            with contextlib.suppress(OSError):
                if backups[path] is None:
                    os.unlink(path)
                else:
                    os.replace(backups[path], path)
                    backups[path] = None
        raise
    finally:
        for backup in backups.values():
            if backup is not None:
                _remove(backup)


def write_together(writers: Sequence[tuple[str | os.PathLike, Callable[[str], None]]],
                   committed: Callable[[], None] | None = None) -> list[Path]:
    """Write a set of files: ``write(temporary)`` for each ``(path, write)``, then rename all, or none.

    ``committed`` runs once every file is in place, before a signal deferred meanwhile arrives.

    Raises
    ------
    GmcptError
        One line naming the file that could not be written and why; every target is then as it was.
    """
    pairs = []
    try:
        for path, write in writers:
            path = Path(path)
            with held():
                pairs.append((path, _temporary(path)))
            try:
                write(pairs[-1][1])
            except (OSError, RuntimeError) as error:  # RuntimeError: OpenEXR and Mitsuba report I/O errors so
                raise _write_error(path, error, pairs[-1][1]) from None
        with held():
            _commit(pairs)
            if committed is not None:
                committed()
    finally:
        with held():
            for _, temporary in pairs:
                _remove(temporary)
    return [path for path, _ in pairs]


def check_writable(path: str | os.PathLike) -> Path:
    """Fail early, with one line, if ``path`` cannot be created or replaced."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    if path.is_dir():
        raise GmcptError(f"output path {path} is a directory")
    if not parent.is_dir():
        raise GmcptError(f"output directory {parent} does not exist")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise GmcptError(f"output directory {parent} is not writable")
    try:  # access() says yes to root, and on /proc: try it
        with held():
            handle, probe = tempfile.mkstemp(prefix=f".{path.name}.", dir=parent)
            os.close(handle)
            os.unlink(probe)
    except OSError as error:
        raise _write_error(path, error) from None
    return path


def check_output(path: str | os.PathLike) -> Path:
    """:func:`check_writable`, but a missing folder is fine if it can be made (:func:`make_folder`, when writing)."""
    path = Path(path)
    if path.parent.exists() and not path.parent.is_dir():
        raise GmcptError(f"output directory {path.parent} is not a folder")
    check_writable(path if path.parent.is_dir() else path.parent)
    return path


def make_folder(path: str | os.PathLike) -> None:
    """Create ``path``'s folder if it is missing (its parent exists: :func:`check_output`)."""
    try:
        Path(path).parent.mkdir(exist_ok=True)
    except OSError as error:
        raise GmcptError(f"cannot create {Path(path).parent}: {error.strerror}") from None


def _same_file(first: Path, second: Path) -> bool:
    with contextlib.suppress(OSError):
        if first.exists() and second.exists():
            return os.path.samefile(first, second)
    return first.resolve() == second.resolve()


def check_not_inputs(outputs: Iterable[Path], inputs: dict[str, Iterable[Path]]) -> None:
    """Refuse (one line) an output that is one of the inputs (``{what: paths}``), which writing would destroy."""
    for output in outputs:
        for what, paths in inputs.items():
            for path in paths:
                if _same_file(Path(output), Path(path)):
                    raise GmcptError(f"output {output} would overwrite the {what} {path}; choose another --out")


def _plain(value):
    """``value`` with only what JSON holds: non-finite numbers as None, numpy scalars and arrays, paths."""
    if isinstance(value, dict):
        return {str(key): _plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(item) for item in value]
    if isinstance(value, Path):
        return str(value)
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # numpy scalars and arrays
        return _plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def json_text(value, indent: int | None = 2) -> str:
    """Strict JSON of ``value`` (``json.loads`` reads it back with NaN refused): non-finite numbers are null."""
    return json.dumps(_plain(value), indent=indent, allow_nan=False) + ("\n" if indent is not None else "")


@contextlib.contextmanager
def captured_output():
    """Keep what native code prints during the block out of the terminal: on file descriptors 1 and 2,
    and through ``sys.stdout`` / ``sys.stderr`` (pybind11's ``print``).

    Yields a dict that holds, after the block, ``{1: text, 2: text}``.
    """
    captured: dict[int, str] = {}
    with contextlib.ExitStack() as stack:
        for descriptor, name in ((1, "stdout"), (2, "stderr")):
            stream = getattr(sys, name)
            try:
                stream.flush()
                saved = os.dup(descriptor)
            except (OSError, ValueError, AttributeError):  # no descriptor to redirect
                saved = None
            sink, text = stack.enter_context(tempfile.TemporaryFile()), io.StringIO()
            if saved is not None:
                os.dup2(sink.fileno(), descriptor)
            setattr(sys, name, text)
            stack.callback(_restore, descriptor, name, stream, saved, sink, text, captured)
        yield captured


def _restore(descriptor: int, name: str, stream, saved: int | None, sink, text: io.StringIO, captured: dict) -> None:
    setattr(sys, name, stream)
    if saved is not None:
        os.dup2(saved, descriptor)
        os.close(saved)
    sink.seek(0)
    captured[descriptor] = sink.read().decode(errors="replace") + text.getvalue()
