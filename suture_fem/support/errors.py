"""Exceptions with the exit codes the command line maps them to."""


class SutureFemError(Exception):
    """Base class; ``exit_code`` is what ``suture-fem`` exits with."""

    exit_code = 1


class SceneError(SutureFemError, ValueError):
    """A scene key is unknown, of the wrong type or out of its allowed range (exit code 2)."""

    exit_code = 2


class SolveStopped(SutureFemError, RuntimeError):
    """The load ramp could not be completed; carries the diagnosis (exit code 3).

    Attributes:
        cause: short machine-readable cause ("cutbacks", "domain", "linear_solver", ...).
        load_reached: last converged force (N).
        attempted: force of the failed attempt (N).
        detail: human-readable diagnosis (region, quantity that hit its limit).
    """

    exit_code = 3

    def __init__(self, cause: str, load_reached: float, attempted: float, detail: str):
        self.cause, self.load_reached, self.attempted, self.detail = cause, load_reached, attempted, detail
        self.history = None  # the solver's RampResult up to the stop, when known
        super().__init__(
            f"solve stopped ({cause}) at {attempted:.6g} N; last converged load {load_reached:.6g} N: {detail}"
        )

    @classmethod
    def with_history(cls, history, **kwargs) -> "SolveStopped":
        stop = cls(**kwargs)
        stop.history = history
        return stop
