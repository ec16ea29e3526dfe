"""One writer per output folder: ``fcntl.flock`` on a lock file inside it, never through a symlink.

A sweep holds ``OUT/.sweep.lock`` and a run ``OUT/.run.lock`` for its life; a second one into the same
folder is refused in one line (exit 2) naming the process, host and start time of the holder. The lock
file is opened with ``O_NOFOLLOW`` and must be a regular file with one link: a symlink, FIFO or hard
link planted under that name is refused, never written through. The lock goes with its process, also
when it is killed.
"""

from __future__ import annotations

import errno
import fcntl
import json
import os
import stat
from pathlib import Path
from typing import Any

from suture_fem.support.errors import SutureFemError
from suture_fem.support.io import FILE_MODE, not_opened, this_process, why


class FolderInUse(SutureFemError):
    """The output folder is held by another process, or its lock file is not ours to write (exit code 2)."""

    exit_code = 2


def _open_lock_file(path: Path, what: str) -> Any:
    flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags, FILE_MODE)
    except OSError as exc:
        reason = not_opened(exc, path) + ("; remove it" if exc.errno == errno.ELOOP else "")
        raise FolderInUse(f"{what} folder {path.parent}: cannot open the lock file {path.name}: {reason}") from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode) or info.st_nlink != 1:
        os.close(fd)
        kind = "not a regular file" if not stat.S_ISREG(info.st_mode) else "a hard link to another file"
        raise FolderInUse(f"{what} folder {path.parent}: the lock file {path.name} is {kind}; remove it")
    return open(fd, "r+")  # noqa: SIM115 (held open for the holder's life)


def lock_folder(out: Path, name: str, what: str) -> Any:
    """Lock ``out`` for this process (``out/name``); returns the open lock file for :func:`release_folder`.

    Raises:
        FolderInUse: another process holds it (naming it), or the lock file is a symlink, FIFO or hard link.
    """
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # a file in the way, no permission, a full disk: exit 1 as any write that fails
        raise SutureFemError(f"creating the output folder {out}: {why(exc, out.parent)}") from None
    path = out / name
    f = _open_lock_file(path, what)
    try:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        try:
            holder = json.loads(f.read())
            who = f"process {holder['pid']} on {holder['host']} since {holder['started_at']}"
        except (ValueError, KeyError, TypeError, OSError):
            who = "another process"
        f.close()
        raise FolderInUse(f"{what} folder {out} is in use by {who}; wait for that {what} to end or give "
                          "another --out") from None
    try:
        same = os.stat(path, follow_symlinks=False).st_ino == os.fstat(f.fileno()).st_ino
    except OSError:
        same = False
    if not same:  # the holder removed it meanwhile: lock the new one
        f.close()
        return lock_folder(out, name, what)
    f.seek(0)
    f.truncate()
    f.write(json.dumps(this_process()) + "\n")
    f.flush()
    return f


def release_folder(lock: Any, out: Path, name: str) -> None:
    """Remove the lock file (while still holding it, so no one locks a removed file unnoticed) and close it."""
    (out / name).unlink(missing_ok=True)
    lock.close()
