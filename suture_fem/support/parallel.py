"""Collective outcomes: what one rank does alone, every rank learns the result of.

An exception raised on one rank while the others wait in a collective call hangs the job. Work done
by rank 0 alone (running gmsh, writing a file) goes through :func:`on_root`, which broadcasts its
outcome: every rank returns, or every rank raises an error with the same message and exit code.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

from suture_fem.support.errors import SutureFemError

log = logging.getLogger("suture_fem")


class CollectiveError(SutureFemError):
    """An error raised on one rank, raised again on every rank with its message and exit code."""

    def __init__(self, message: str, exit_code: int):
        super().__init__(message)
        self.exit_code = exit_code


def on_root(comm: Any, what: str, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """Call ``fn(*args, **kwargs)`` on rank 0 of ``comm`` (collective).

    Returns fn's result on rank 0 and None elsewhere. When fn raises, every rank raises: rank 0 the
    original SutureFemError (any other exception becomes ``CollectiveError("<what>: <exception>")``),
    the other ranks a CollectiveError with the same message and exit code.
    """
    result, failure, raised = None, None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except SutureFemError as exc:
            failure, raised = (str(exc), exc.exit_code), exc
        except Exception as exc:  # noqa: BLE001 (any failure here must reach the other ranks)
            log.debug("%s failed", what, exc_info=True)
            failure = (f"{what}: {exc}", SutureFemError.exit_code)
            raised = CollectiveError(*failure)
            raised.__cause__ = exc
    failure = comm.bcast(failure, root=0)
    if failure is not None:
        raise raised if raised is not None else CollectiveError(*failure)
    return result


def wait(request: Any, timeout_s: float | None = None, poll_s: float = 0.05) -> bool:
    """Wait for a non-blocking MPI request without spinning a core; False if ``timeout_s`` passed first.

    Open MPI's blocking waits poll at full speed, which takes a core away from ranks that still
    compute on an oversubscribed machine.
    """
    start = time.monotonic()
    while not request.Test():
        if timeout_s is not None and time.monotonic() - start > timeout_s:
            return False
        time.sleep(poll_s)
    return True
