"""The scene folders: ``OUT/NNN-HASH``, complete or absent, and their ``status.json``.

Each folder is filled in a hidden staging folder and renamed into place when the scene is finished,
so it is complete or absent; it holds ``results.json`` (and the fields if asked) and ``status.json``:
status (converged, stopped, invalid, error), exit code, message, the reproducing command, and
``solve_count``. Running the same sweep again skips the scenes whose folder exists (converged,
stopped or invalid; an "error" is retried) unless ``--redo``.
"""

from __future__ import annotations

import fcntl
import os
import shutil
from pathlib import Path
from typing import Any

from suture_fem.studies.sweep.plan import SweepError
from suture_fem.support.folder_lock import FolderInUse, _open_lock_file, lock_folder, release_folder
from suture_fem.support.io import read_json, remove, write_json

FINISHED = ("converged", "stopped", "invalid")  # a folder with one of these is not solved again


def read_status(folder: Path) -> dict[str, Any] | None:
    """A scene folder's status.json, or None when it has none (or it cannot be read)."""
    try:
        return read_json(folder / "status.json")
    except (OSError, ValueError):
        return None


def finished_scenes(out: Path) -> dict[str, str]:
    """Folder name -> status of every scene folder under ``out`` that has a status.json."""
    found: dict[str, str] = {}
    if out.is_dir():
        for folder in sorted(out.iterdir()):
            status = read_status(folder) if folder.is_dir() and not folder.name.startswith(".") else None
            if status is not None:
                found[folder.name] = status.get("status", "error")
    return found


def fresh_folder(folder: Path) -> None:
    """An empty folder at ``folder`` (whatever was there is removed; a symlink itself, never its target)."""
    remove(folder)
    folder.mkdir(parents=True)


def publish(staging: Path, final: Path, status: dict[str, Any]) -> None:
    """Write status.json into the staging folder and rename it into place (replacing an old one)."""
    write_json(staging / "status.json", status)
    if final.exists():
        old = final.with_name(f".{final.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(final, old)
        os.replace(staging, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(staging, final)


LOCK_NAME = ".sweep.lock"


def take_lock(out: Path) -> Any:
    """Lock the sweep folder for this sweep's life (``fcntl.flock`` on ``OUT/.sweep.lock``, never through a symlink).

    Returns the open lock file (the lock goes when :func:`release_lock` removes and closes it, or
    when the process ends, also when it is killed). A folder another sweep holds raises SweepError
    naming its process, host and start time.
    """
    try:
        return lock_folder(out, LOCK_NAME, "sweep")
    except FolderInUse as exc:
        raise SweepError(str(exc)) from None


def release_lock(lock: Any, out: Path) -> None:
    """Remove the lock file (while still holding it, so no one locks a removed file unnoticed) and close it."""
    release_folder(lock, out, LOCK_NAME)


def _lock_open(path: Path, mode: int) -> Any:
    """``path`` opened and flock'ed (``mode`` without blocking), or None when another process holds it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    f = _open_lock_file(path, "sweep")  # never through a symlink, FIFO or hard link planted there
    try:
        fcntl.flock(f.fileno(), mode | fcntl.LOCK_NB)
    except OSError:
        f.close()
        return None
    if not path.exists() or os.stat(path, follow_symlinks=False).st_ino != os.fstat(f.fileno()).st_ino:
        f.close()  # its holder removed it meanwhile: lock the new one
        return _lock_open(path, mode)
    return f


def take_task_locks(out: Path, name: str) -> tuple[Any, Any]:
    """The locks of a Slurm array task solving scene ``name``: the sweep folder shared, the scene exclusive.

    The shared lock keeps a local sweep (which locks the folder exclusively) out while tasks run;
    SweepError when a local sweep or another task solving the same scene holds one of them.
    """
    sweep_lock = _lock_open(out / LOCK_NAME, fcntl.LOCK_SH)
    if sweep_lock is None:
        raise SweepError(f"sweep folder {out} is in use by a sweep that is not a Slurm task; wait for it to end")
    scene_lock = _lock_open(out / f".{name}.lock", fcntl.LOCK_EX)
    if scene_lock is None:
        sweep_lock.close()
        raise SweepError(f"scene {name} is being solved by another task; nothing to do")
    return sweep_lock, scene_lock


def release_task_locks(out: Path, name: str, locks: tuple[Any, Any]) -> None:
    """Remove the scene's lock file (while holding it) and release both locks."""
    (out / f".{name}.lock").unlink(missing_ok=True)
    for lock in locks:
        lock.close()


def scene_busy(out: Path, name: str) -> bool:
    """Whether a process holds scene ``name``'s lock (a task is solving it)."""
    path = out / f".{name}.lock"
    try:
        with open(os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)) as f:
            fcntl.flock(f.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
    except FileNotFoundError:
        return False
    except OSError:
        return True
    return False
