"""Child processes end with their parent: when it stops in order, and when it is killed outright.

``convergence`` runs its rungs and ``reproduce`` its ramps as ``python -P -m suture_fem.cli ...``
children. :func:`popen` starts one with the parent's pid in its environment; the child's command line
calls :func:`end_with_parent`, which asks Linux to send it SIGTERM when the parent dies
(``prctl(PR_SET_PDEATHSIG)``), whatever killed the parent (``kill -9`` included); the child then
stops in order, as on any SIGTERM. :func:`running` terminates a child whose parent leaves the block
by an exception (an interrupt included) and waits for it.

Written by hand with ctypes: the standard library has no prctl, and the one call does not justify a
compiled dependency. ``start_new_session`` would not do it: a child in its own session outlives a
killed parent all the same, and no longer gets the terminal's Ctrl-C.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from typing import Any

log = logging.getLogger("suture_fem")

#: The environment variable that carries the parent's pid to a child started by :func:`popen`.
PARENT_PID = "SUTURE_FEM_PARENT_PID"
PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
#: How long a terminated child may take to stop in order before it is killed (s).
TERMINATE_GRACE_S = 60.0


def popen(cmd: list[str], **kwargs: Any) -> subprocess.Popen:
    """``subprocess.Popen(cmd, **kwargs)``, the child told to end with this process (see :func:`end_with_parent`)."""
    env = dict(kwargs.pop("env", None) or os.environ)
    env[PARENT_PID] = str(os.getpid())
    return subprocess.Popen(cmd, env=env, **kwargs)


@contextlib.contextmanager
def running(cmd: list[str], **kwargs: Any) -> Iterator[subprocess.Popen]:
    """:func:`popen` for a ``with`` block; a child still running when the block raises is stopped."""
    proc = popen(cmd, **kwargs)
    try:
        yield proc
    except BaseException:
        stop(proc)
        raise


def stop(proc: subprocess.Popen) -> None:
    """Terminate a child (it stops in order), kill it after :data:`TERMINATE_GRACE_S`, and reap it."""
    if proc.returncode is not None:
        return
    with contextlib.suppress(ProcessLookupError):
        proc.terminate()
    try:
        proc.wait(TERMINATE_GRACE_S)
    except subprocess.TimeoutExpired:
        log.warning("child process %d did not stop within %g s; killed", proc.pid, TERMINATE_GRACE_S)
        proc.kill()
        proc.wait()
    except ChildProcessError:  # already reaped (os.wait4 by the caller)
        pass


def end_with_parent() -> None:
    """In a child started by :func:`popen`: get SIGTERM when the parent dies (Linux); at once if it has already."""
    parent = os.environ.pop(PARENT_PID, None)  # not passed on to this process's own children
    if parent is None or not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM), 0, 0, 0) != 0:
        log.warning("prctl(PR_SET_PDEATHSIG) failed (errno %d): this process may outlive its parent",
                    ctypes.get_errno())
        return
    if os.getppid() != int(parent):  # the parent died before the request: nothing will send the signal
        os.kill(os.getpid(), signal.SIGTERM)
