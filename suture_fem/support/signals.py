"""SIGINT, SIGTERM and SIGHUP end a command in order, on every rank; the first signal decides.

The command line installs :func:`handler` for the three (after PETSc's initialisation, which sets
its own). What a signal does:

* The first one received is the one that counts: results.json says "interrupted by SIGNAME" and the
  exit code is 128 + its number (130 SIGINT, 143 SIGTERM, 129 SIGHUP). A later one (Ctrl-C pressed
  again, a SIGTERM after it) is ignored, so it can never break the orderly stop half-way or change
  which signal the run reports; SIGKILL still ends a process at once.
* In a single process it raises :class:`~suture_fem.support.errors.Interrupted` at once. Where that
  exception is swallowed (by compiled code that cannot pass it on, e.g. a callback PETSc calls), the
  next :func:`check` raises it again: the solver checks at every residual and Jacobian, the load ramp
  after every converged step.
* Inside :func:`held` (writing results.json) it is only recorded, and raised at the next check.
* Under MPI it only records the signal: a rank that raised alone would leave the others waiting in a
  collective call for ever. :func:`check` is collective: when any rank of the communicator has
  received a signal, every rank raises Interrupted for the same signal (that of the lowest rank that
  received one), and the ranks stop together.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

from suture_fem.support.errors import Interrupted

#: The signals that end a command in order.
HANDLED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

_received: int | None = None  # the first signal received since install()
_at_once = True  # raise in the handler (a single process) or only record (several ranks)


def received() -> int | None:
    """The number of the first signal received since :func:`install`, or None."""
    return _received


def handler(signum: int, frame: Any) -> None:
    """Record the first signal; in a single process raise Interrupted for it. Later signals are ignored."""
    global _received
    if _received is not None:
        return
    _received = signum
    if _at_once:
        raise Interrupted(signum)


@contextlib.contextmanager
def held() -> Iterator[None]:
    """A block no signal breaks half-way (writing results.json): one that arrives is only recorded.

    The next :func:`check` after the block raises it (or, when the block is the last word of a run
    that already ended for another reason, it is one of the later signals that are ignored).
    """
    global _at_once
    before, _at_once = _at_once, False
    try:
        yield
    finally:
        _at_once = before


def install(ranks: int) -> dict[int, Any]:
    """Handle :data:`HANDLED` (main thread only); ``ranks``: the command's MPI size. Returns the old handlers."""
    global _received, _at_once
    if threading.current_thread() is not threading.main_thread():
        return {}
    _received, _at_once = None, ranks == 1
    return {s: signal.signal(s, handler) for s in HANDLED}


def restore(previous: dict[int, Any]) -> None:
    """Put back the handlers :func:`install` replaced and forget any signal received."""
    global _received
    for signum, old in previous.items():
        signal.signal(signum, old)
    _received = None
    Interrupted.pending = None


def check(comm: Any) -> None:
    """Raise Interrupted on every rank of ``comm`` when one of them has received a signal (collective).

    A single process needs no communication: it raises again a signal whose exception was swallowed.
    """
    if comm.size == 1:
        signum = _received
    else:
        signum = next((s for s in comm.allgather(_received) if s is not None), None)
    if signum is not None:
        raise Interrupted.pending if Interrupted.pending is not None and Interrupted.pending.signum == signum \
            else Interrupted(signum)
