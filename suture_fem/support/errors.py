"""Exceptions with the exit codes the command line maps them to, and the typed cause of a stopped solve."""

from __future__ import annotations

from enum import StrEnum
from typing import Any


class StopCause(StrEnum):
    """Why a load path stopped: the ``diagnosis.cause`` of results.json.

    A ``str`` enum: a member equals (and serialises to JSON as) its value, so results.json reads the
    same and a comparison with the plain string still holds.
    """

    #: a converged state reached ``solver.gent_limit_fraction`` of Gent's locking limit (or trial
    #: states kept crossing the limit itself)
    GENT_LIMIT = "gent_limit"
    #: trial states kept inverting elements (J <= 0)
    INVERTED_ELEMENT = "inverted_element"
    #: Newton did not converge although every trial state was admissible
    NEWTON_DIVERGENCE = "newton_divergence"
    #: the direct linear solver failed (and no fallback was left)
    LINEAR_SOLVER = "linear_solver"
    #: nothing holds the thread axially: a frictionless sliding thread with no cone tied to the tissue
    #: passes no axial force, so no equilibrium exists under a pulling force
    NO_AXIAL_SUPPORT = "no_axial_support"


#: Longest value an error message quotes, and longest message printed (characters).
SHOWN_CHARS = 80
MESSAGE_CHARS = 1000


def shown(value: Any) -> str:
    """A value as a message quotes it: its repr (control characters escaped), cut to SHOWN_CHARS."""
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else f"{text[:SHOWN_CHARS]}... ({len(text):,} characters)"


def one_line(message: str) -> str:
    """A message as the terminal gets it: control characters escaped, cut to MESSAGE_CHARS."""
    text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)
    return text if len(text) <= MESSAGE_CHARS else f"{text[:MESSAGE_CHARS]}... ({len(text):,} characters)"


class SutureFemError(Exception):
    """Base class; ``exit_code`` is what ``suture-fem`` exits with."""

    exit_code = 1


class SceneError(SutureFemError, ValueError):
    """A scene key is unknown, of the wrong type or out of its allowed range (exit code 2)."""

    exit_code = 2


class SolveStopped(SutureFemError, RuntimeError):
    """The load ramp could not be completed; carries the diagnosis (exit code 3).

    Attributes:
        cause: why (:class:`StopCause`; equal to its string value, e.g. "gent_limit").
        load_reached: last converged force (N).
        attempted: force of the failed attempt (N).
        detail: human-readable diagnosis (region, quantity that hit its limit).
        history: the solver's RampResult up to the stop, when known.
    """

    exit_code = 3

    def __init__(self, cause: StopCause, load_reached: float, attempted: float, detail: str):
        """Store the diagnosis; the message names the cause, the forces and the detail."""
        self.cause, self.load_reached, self.attempted, self.detail = cause, load_reached, attempted, detail
        self.history: Any = None
        super().__init__(
            f"solve stopped ({cause}) at {attempted:.6g} N; last converged load {load_reached:.6g} N: {detail}"
        )

    @classmethod
    def with_history(cls, history: Any, **kwargs: Any) -> SolveStopped:
        """A SolveStopped that also carries the solver's history up to the stop."""
        stop = cls(**kwargs)
        stop.history = history
        return stop


class Interrupted(KeyboardInterrupt):
    """SIGINT (Ctrl-C), SIGTERM or SIGHUP arrived: the run ends, results.json says "interrupted".

    ``exit_code`` is 128 + the signal's number (130 SIGINT, 143 SIGTERM, 129 SIGHUP), as a shell reports
    it. When and where it is raised: :mod:`suture_fem.support.signals`.
    """

    #: The signal raised in this process and not yet handled: a signal that arrives inside a PETSc
    #: callback (petsc4py 3.22) reaches Python as a PETSc error, and the solver re-raises it from here.
    pending: Interrupted | None = None

    def __init__(self, signum: int):
        """Record the signal (its number and name)."""
        import signal

        self.signum, self.exit_code = signum, 128 + signum
        self.name = signal.Signals(signum).name
        super().__init__(self.name)
        Interrupted.pending = self
