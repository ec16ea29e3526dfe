"""Files: complete or absent.

Every file is written to a temporary name in its folder, flushed to disk and checked (its size is
the size written) before it is renamed into place; on any failure (a full disk, an interrupt) the
temporary file is removed, so a reader finds the old file, the new file, or none, never a truncated
one. :func:`commit` does the same check and rename for a file another library wrote (gmsh, HDF5).
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import platform
import shutil
import tempfile
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from suture_fem.support.errors import SceneError, SutureFemError


class WriteError(SutureFemError):
    """A file could not be written completely (exit code 1); the partial file has been removed."""


def _clean(obj: Any) -> Any:
    """JSON-safe copy: numpy scalars to Python, non-finite floats to None (never NaN in a file)."""
    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item) and getattr(obj, "ndim", 1) == 0:
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def why(exc: BaseException, folder: Path) -> str:
    """A write's failure in a few words, with the free space of ``folder``'s disk when the disk is full."""
    text = (exc.strerror if isinstance(exc, OSError) else None) or str(exc)
    try:
        free = shutil.disk_usage(folder).free
        if getattr(exc, "errno", None) == 28 or free < 1 << 20:  # ENOSPC, or less than 1 MiB left
            text += f" ({free / 1024:.0f} KiB free on the disk of {folder})"
    except OSError:
        pass
    return text


def sync_folder(folder: Path) -> None:
    """Flush a folder's entries (a rename into it) to disk; a no-op where folders cannot be opened."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def commit(tmp: Path, path: Path, size: int | None = None) -> Path:
    """Check that ``tmp`` is complete and on disk, then rename it to ``path``; remove it otherwise.

    Args:
        tmp: the file just written (in ``path``'s folder).
        path: its final name.
        size: the bytes that should be in it; None: only check that it is not empty.

    Raises:
        WriteError: the file is missing, empty or short, or cannot be flushed (it is removed).
    """
    with _removed_on_failure(tmp, path):
        fd = os.open(tmp, os.O_RDWR | os.O_NOFOLLOW)
        try:
            os.fsync(fd)
            actual = os.fstat(fd).st_size
        finally:
            os.close(fd)
        if (size is not None and actual != size) or (size is None and actual == 0):
            expected = f"{size} bytes" if size is not None else "some bytes"
            raise WriteError(f"writing {path}: {actual} bytes on disk, expected {expected} "
                             f"({why(OSError(28, 'short write'), path.parent)}); nothing was written")
        os.replace(tmp, path)
    sync_folder(path.parent)
    return path


@contextlib.contextmanager
def _removed_on_failure(tmp: Path, path: Path) -> Iterator[None]:
    """Remove ``tmp`` if the block fails; an OSError becomes one WriteError line naming ``path``."""
    try:
        yield
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise WriteError(f"writing {path}: {why(exc, path.parent)}; nothing was written") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def usable_folder(path: str | Path, option: str = "--out") -> Path:
    """``path`` if it is, or can be made, a folder this process writes into; SceneError (exit 2) if not.

    Checked before any work, creating nothing that stays: the path itself, else its nearest existing
    parent, must be a folder a file can be created in (not a file, not read-only).
    """
    path = Path(path)
    probe = path
    while not os.path.lexists(probe) and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        what = "is a file" if probe == path else f"cannot be made: {probe} is a file"
        raise SceneError(f"{option} {path}: {what}, not a folder; give a folder path")
    try:  # a probe file, removed at once: root passes every permission test, a read-only disk does not
        fd, name = tempfile.mkstemp(dir=probe, prefix=".suture-fem-probe-")
        os.close(fd)
        os.unlink(name)
    except OSError as exc:
        raise SceneError(f"{option} {path}: {probe} cannot be written ({exc.strerror or exc})") from None
    return path


def _file_mode() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


#: The permissions of a new file (what ``open(path, "w")`` would give under this process's umask).
FILE_MODE = _file_mode()


def _create_temporary(path: Path, suffix: str) -> tuple[int, Path]:
    try:
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix, dir=path.parent)
    except OSError as exc:
        raise WriteError(f"writing {path}: {why(exc, path.parent)}; nothing was written") from None
    os.fchmod(fd, FILE_MODE)
    return fd, Path(name)


def temporary_name(path: Path, suffix: str = ".tmp") -> Path:
    """A new empty hidden file beside ``path`` to write under before :func:`commit` renames it.

    Its name is unpredictable and it is created exclusively (``O_CREAT | O_EXCL | O_NOFOLLOW``, as
    ``tempfile.mkstemp`` does), so a symlink or file planted in the folder is never written through.
    """
    fd, tmp = _create_temporary(path, suffix)
    os.close(fd)
    return tmp


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write bytes atomically: a new temporary file in the same folder, flushed, checked, then renamed.

    The rename replaces whatever ``path`` was (a planted symlink too) and never follows it.

    Raises:
        WriteError: the disk is full or the file cannot be written (the temporary file is removed).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = _create_temporary(path, ".tmp")
    with _removed_on_failure(tmp, path), open(fd, "wb") as f:
        f.write(data)
        f.flush()
    return commit(tmp, path, len(data))


def write_text(path: str | Path, text: str) -> Path:
    """Write text atomically (UTF-8) as :func:`write_bytes` does."""
    return write_bytes(path, text.encode("utf-8"))


def save_figure(fig: Any, path: str | Path, **savefig: Any) -> Path:
    """A matplotlib figure as a PNG, complete or absent (rendered in memory, then :func:`write_bytes`)."""
    import io as _io

    buf = _io.BytesIO()
    fig.savefig(buf, format="png", **savefig)
    return write_bytes(path, buf.getvalue())


def open_new(path: str | Path, mode: str = "w") -> Any:
    """Open a file for writing in place (a log), never through a symlink; an existing file is emptied.

    Raises:
        WriteError: ``path`` is a symlink or cannot be created.
    """
    path = Path(path)
    flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags, FILE_MODE)
    except OSError as exc:
        raise WriteError(f"writing {path}: {not_opened(exc, path)}; nothing was written") from None
    return open(fd, mode)  # noqa: SIM115 (the caller closes it)


def not_opened(exc: OSError, path: Path) -> str:
    """Why an ``O_NOFOLLOW`` open of ``path`` failed, in a few words (a planted symlink named as such)."""
    return "it is a symbolic link" if exc.errno == errno.ELOOP else why(exc, path.parent)


def write_json(path: str | Path, data: Any) -> Path:
    """Write JSON atomically (numpy scalars as Python numbers, non-finite floats as null)."""
    return write_text(path, json.dumps(_clean(data), indent=2, allow_nan=False) + "\n")


def read_json(path: str | Path) -> Any:
    """Read a JSON file."""
    return json.loads(Path(path).read_text())


def remove(*paths: Path) -> None:
    """Remove files or folders if they exist (stale outputs of an earlier run, partial files)."""
    for p in paths:
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)


def this_process() -> dict[str, Any]:
    """Who writes a file: process id, host and start time (so a reader can tell a dead run from a live one)."""
    return {"pid": os.getpid(), "host": platform.node(),
            "started_at": datetime.now(UTC).isoformat(timespec="seconds")}


def process_alive(record: dict[str, Any]) -> bool | None:
    """Whether the process a :func:`this_process` record names still runs; None when it ran on another host."""
    if record.get("host") != platform.node():
        return None
    try:
        os.kill(int(record["pid"]), 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    except (KeyError, TypeError, ValueError):
        return None
    return True
