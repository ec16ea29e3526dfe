"""When a Newton solve stops: PETSc's residual tests, the increment test, the hand-over to full steps, a stall.

:class:`NewtonSolver <suture_fem.solve.newton.NewtonSolver>` installs :meth:`StopTests.converged` as
SNES's convergence test where the line search decides on the energy (degree 1, static, plain
displacement), and asks after every solve whether to go on from the
current iterate with the residual tests only (:meth:`StopTests.finish`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

import numpy as np
from petsc4py import PETSc

from suture_fem.scene.balance import BALANCE_TOL

log = logging.getLogger("suture_fem")

#: Newton-increment stopping test (SNES ``stol``): a solve stops when its last increment is below this
#: fraction of the state. With Newton converging at any rate below 1/2 the remaining error is below the
#: last increment, so the answer is exact to about 1e-7 relative, ten times inside the 1e-6 the answers
#: must keep. Measured on the paper scene: P2 63 -> 55 Newton iterations per ramp, USUM
#: changed by 8e-13 (benchmarks/speed.py).
INCREMENT_RTOL = 1e-7
#: A solve stopped by the increment test whose residual is above this fraction of the applied force (N)
#: continues with the residual tests only, so the reaction still balances the pull to 1e-9 of the force
#: (a short damped step of the line search, not convergence, can also make the increment small). At
#: 1e-7 a 1-cone P1 run at 2 N ended at a free residual of 1.3e-7 N on Debian 13, above the 1e-8 of the
#: force the integration tests hold every run to.
INCREMENT_STOP_RESIDUAL = 1e-9
#: An energy line search that fails below this fraction of the applied force (N) in residual has met the
#: rounding of the energy, not a divergence: the solve goes on with full Newton steps from where it is.
FULL_STEP_RESIDUAL = 1e-6
#: A solve with the energy line search whose residual is still above STALL_FRACTION of its start after
#: STALL_ITERATIONS iterations is given up (and the step cut) instead of running to ``solver.max_iterations``:
#: the energy may fall while the residual does not (measured: the paper scene with 0.04 mm fillets at P1,
#: first step 0.4 N, residual 0.30 -> 0.82 -> 0.49 after 10 iterations, 0.076 after 25, failed; the
#: converging first steps measured were below 0.75 of their start after 10 iterations).
STALL_ITERATIONS = 10
STALL_FRACTION = 0.9


def stall_iterations(problem: Any) -> int | None:
    """STALL_ITERATIONS, or None (no stall rule: solves run to ``solver.max_iterations``) on a unilateral thread at P2.

    On the thread's semismooth penalty the residual of a converging solve can stay above its start for more
    than 10 iterations while the energy falls, as track nodes open and close (measured, paper scene, P2,
    frictionless thread: solves of 17-24 iterations that converge; with the rule one cone stopped at 1.82 N
    and four crossed 0.92 N only by a leap; without it both reach 4 N: docs/contact.md). At P1 the rule
    stays: lifting it there moved the one-cone ramp to another equilibrium (USUM 8.411 against 8.375 mm at
    4 N, of lower energy), and the P1 answers are kept.
    """
    effects = getattr(problem, "effects", None)
    lifted = effects is not None and effects.unilateral_thread and getattr(problem, "degree", 1) != 1
    return None if lifted else STALL_ITERATIONS


class StopTests:
    """The convergence test of a solve on the energy line search, and the decision to finish with full steps.

    ``on_energy()``: whether the backtracking line search decides on the energy now; ``force()``: the
    applied force (N), the scale of the residual tests; ``divtol``: SNES's divergence tolerance.
    ``full_steps`` is set while a solve finishes with full steps.
    """

    def __init__(self, on_energy: Callable[[], bool], force: Callable[[], float], divtol: float,
                 stall: int | None = STALL_ITERATIONS):
        """The line-search state and the force scale, as callables (both change between solves).

        ``stall``: the iterations after which a solve that has not made progress is given up (None: never).
        """
        self.on_energy, self.force, self.divtol, self.stall = on_energy, force, divtol, stall
        self.fnorm0 = 0.0
        self.full_steps = False
        self.loose = 0.0  # a fixed point's early solve: its looser residual test (N; 0: none)

    def energy_line_search(self) -> bool:
        """True while the backtracking line search decides on the energy (not while finishing with full steps)."""
        return self.on_energy() and not self.full_steps

    def converged(self, snes: Any, its: int, norms: tuple[float, float, float]) -> int:
        """PETSc's default convergence test, plus the hand-over to full steps and the stall (energy line search).

        The tests and their order are those of PETSc's SNESConvergedDefault (absolute and relative
        residual, function-evaluation count, increment, divergence); petsc4py 3.18 cannot call the default
        from a Python test, so they are restated here. Added: once the residual is below
        FULL_STEP_RESIDUAL x force the solve returns CONVERGED_ITS, and the solver goes on with full
        Newton steps, instead of an energy line search that can no longer see the decrease (it then
        spent one more Jacobian and failed); a solve still above STALL_FRACTION of its first residual
        after STALL_ITERATIONS iterations is given up.
        """
        xnorm, ynorm, fnorm = norms
        rtol, atol, stol, _ = snes.getTolerances()
        reasons = PETSc.SNES.ConvergedReason
        if its == 0:
            self.fnorm0 = fnorm
        if not np.isfinite(fnorm):
            return reasons.DIVERGED_FNORM_NAN
        if fnorm < atol:
            return reasons.CONVERGED_FNORM_ABS
        if snes.getFunctionEvaluations() >= snes.getMaxFunctionEvaluations() >= 0:
            return reasons.DIVERGED_FUNCTION_COUNT
        if its == 0:
            return reasons.CONVERGED_ITERATING
        if fnorm <= rtol * self.fnorm0:
            return reasons.CONVERGED_FNORM_RELATIVE
        if ynorm < stol * xnorm:
            return reasons.CONVERGED_SNORM_RELATIVE
        if self.divtol > 0 and fnorm > self.divtol * self.fnorm0:
            return reasons.DIVERGED_DTOL
        if self.energy_line_search() and fnorm < FULL_STEP_RESIDUAL * self.force():
            return reasons.CONVERGED_ITS
        stalled = self.stall is not None and its >= self.stall and fnorm > STALL_FRACTION * self.fnorm0
        if self.energy_line_search() and stalled:
            log.info("Newton makes no progress: the residual is still %.0f %% of its start after %d iterations; "
                     "the step is given up", 100 * fnorm / self.fnorm0, its)
            return reasons.DIVERGED_MAX_IT
        return reasons.CONVERGED_ITERATING

    def finish(self, snes: Any) -> str | None:
        """How a solve that stopped before its residual tests were met goes on: "full steps", "line search" or None.

        Three ways to stop short: the increment test stopped it at a residual above
        INCREMENT_STOP_RESIDUAL x force (a short damped step also makes the increment small);
        :meth:`converged` handed over; or the energy line search failed at a residual below
        FULL_STEP_RESIDUAL x force. The last two are round-off, not divergence: near the solution the
        energy decrease of a Newton step (about |R|^2 / stiffness) falls below the rounding of the energy
        (measured: the paper scene at P1 stalled at |R| = 6.5e-8 N at 3 N and failed the step). Below
        FULL_STEP_RESIDUAL x force the solve goes on with full Newton steps; an increment stop above it
        (possibly far from balance) goes on with its own line search, as does any other stop short of
        BALANCE_TOL x force (a relative test met far from balance).
        """
        reason, reasons = snes.getConvergedReason(), PETSc.SNES.ConvergedReason
        fnorm, force = snes.getFunctionNorm(), self.force()
        if reason > 0 and fnorm <= self.loose:
            return None  # a fixed point's early solve, converged to its looser test
        relative = (reasons.CONVERGED_FNORM_RELATIVE, reasons.CONVERGED_SNORM_RELATIVE)
        if reason in relative and fnorm > BALANCE_TOL * force:
            return "line search"  # a relative or increment test met short of balance: go on
        if reason == reasons.CONVERGED_SNORM_RELATIVE and fnorm > INCREMENT_STOP_RESIDUAL * force:
            return "full steps" if fnorm < FULL_STEP_RESIDUAL * force else "line search"
        if reason == reasons.CONVERGED_ITS:
            return "full steps"
        if self.energy_line_search() and reason == reasons.DIVERGED_LINE_SEARCH and fnorm < FULL_STEP_RESIDUAL * force:
            return "full steps"
        return None


def force_scale(problem: Any) -> float:
    """The force a problem applies now (N), the scale of the residual tests (1 N without a pull)."""
    force = getattr(problem, "applied_force_n", None)
    scale = abs(force()) if callable(force) else 0.0
    return scale if scale > 0 else 1.0
