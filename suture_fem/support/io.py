"""Files: complete or absent.

Every file is written to a temporary name in its folder, flushed to disk and checked (its size is
the size written) before it is renamed into place; on any failure (a full disk, an interrupt) the
temporary file is removed, so a reader finds the old file, the new file, or none, never a truncated
one. :func:`commit` does the same check and rename for a file another library wrote (gmsh, HDF5).
"""

from __future__ import annotations

import contextlib
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
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
            actual = os.fstat(f.fileno()).st_size
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


def temporary_name(path: Path) -> Path:
    """The hidden temporary name a file is written under before :func:`commit` renames it."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def write_text(path: str | Path, text: str) -> Path:
    """Write text atomically: a temporary file in the same folder, flushed, checked, then renamed.

    Raises:
        WriteError: the disk is full or the file cannot be written (the temporary file is removed).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_name(path)
    data = text.encode("utf-8")
    with _removed_on_failure(tmp, path), open(tmp, "wb") as f:
        f.write(data)
        f.flush()
    return commit(tmp, path, len(data))


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
