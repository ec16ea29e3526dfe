"""The scene folders: ``OUT/NNN-HASH``, complete or absent, and their ``status.json``.

Each folder is filled in a hidden staging folder and renamed into place when the scene is finished,
so it is complete or absent; it holds ``results.json`` (and the fields if asked) and ``status.json``:
status (converged, stopped, invalid, error), exit code, message, the reproducing command, and
``solve_count``. Running the same sweep again skips the scenes whose folder exists (converged,
stopped or invalid; an "error" is retried) unless ``--redo``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from suture_fem.studies.sweep.plan import SweepError
from suture_fem.support.folder_lock import FolderInUse, lock_folder, release_folder
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
