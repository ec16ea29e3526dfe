"""What a load path did: per-step records, counters and the time spent in each part of a solve."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Timings:
    """Seconds spent in each part of a solve."""

    assembly: float = 0.0
    linear_solve: float = 0.0
    guard: float = 0.0
    form_compilation: float = 0.0
    newton_total: float = 0.0
    #: the outputs' evaluation at the reported forces (the critical-distance searches are most of it)
    outputs: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """Every timing, rounded to 0.1 ms, for results.json."""
        return {k: round(v, 4) for k, v in self.__dict__.items()}


@dataclass
class StepRecord:
    """One converged step of the pull: its force (N), Newton iterations, step length and time (s, inertia)."""

    force_n: float
    iterations: int
    step: float
    time_s: float | None = None


@dataclass
class RampResult:
    """What the load path did."""

    steps: list[StepRecord] = field(default_factory=list)
    cutbacks: int = 0
    newton_iterations: int = 0
    linear_solver: str = ""
    fallbacks: list[str] = field(default_factory=list)
    domain_rejections: int = 0
    #: Newton iterations whose Jacobian had negative pivots and was shifted (solve/inertia.py)
    inertia_shifts: int = 0
    line_search_switches: int = 0
    #: long steps tried where a ramp with contact would have stopped (solve/stepping.py)
    leaps: int = 0
    #: largest round-off floor of the residual (N) used as the absolute tolerance, and in how many solves
    #: it was above ``solver.atol``
    residual_floor_n: float = 0.0
    floor_above_atol: int = 0
    unknowns: int = 0
    #: the path-following start (solve/start.py): its end displacement, force and Newton iterations; None without
    start: dict[str, float] | None = None
    #: the trust region's counts (solve/trust.py: solves, converged, iterations, factorisations); None without one
    trust_region: dict[str, int] | None = None
    timings: Timings = field(default_factory=Timings)
