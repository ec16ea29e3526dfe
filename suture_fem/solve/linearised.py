"""Linear solves with the Newton solver's factorisation: the load rate, the tangent du/ds, A x = b.

The stepping's tangent predictor (:mod:`suture_fem.solve.stepping`) and the calibration's direct-method
sensitivities (:mod:`suture_fem.studies.calibrate.sensitivity`) solve with the Jacobian at a converged
state; the Newton solve has just factorised it (at its last iterate), so each costs one back-substitution
(unless the inertia correction shifted that last factorisation: then A is assembled and factorised again,
:meth:`Linearised.solve_reduced`).
A mixin of :class:`~suture_fem.solve.newton.NewtonSolver`, whose attributes it uses.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from petsc4py import PETSc

from suture_fem.support import compat
from suture_fem.support.errors import Interrupted


class Linearised:
    """:class:`~suture_fem.solve.newton.NewtonSolver`'s solves with its Jacobian (a mixin)."""

    snes: Any
    x: Any
    b: Any
    A: Any
    reduction: Any
    physics: Any
    timings: Any
    #: set when a Jacobian was assembled in the current solve (the factorisation is then of this solve)
    jacobian_current: bool = False

    def load_rate(self, set_load: Any, s: float) -> Any:
        """-dR/ds on the unknowns (a new vector), ``set_load(v)`` setting the loads at path parameter v.

        The pull and the weight are dead loads, linear in s: R(u, s + 1) - R(u, s) is dR/ds at every u.
        """
        r0, r1 = self.b.duplicate(), self.b.duplicate()
        try:
            set_load(s + 1.0)
            self._residual(self.snes, self.x, r1)
            set_load(s)
            self._residual(self.snes, self.x, r0)
            r1.axpy(-1.0, r0)
            r1.scale(-1.0)
            return r1
        finally:
            set_load(s)
            self.reduction.expand(self.x)
            r0.destroy()

    def tangent(self, rate: Any, out: Any) -> bool:
        """Du/ds into ``out`` (state layout): A du/ds = ``rate`` by :meth:`solve_reduced`; False when it failed."""
        dx = self.x.duplicate()
        try:
            if not self.solve_reduced(rate, dx):
                return False
            self.reduction.T.mult(dx, out)
            out.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            return True
        except PETSc.Error:
            if Interrupted.pending is not None:
                raise Interrupted.pending from None
            return False
        finally:
            dx.destroy()

    def solve_reduced(self, b: Any, x: Any) -> bool:
        """A x = b, A the Jacobian at the current state; False: failed.

        After a solve that assembled a Jacobian, by the last Newton iteration's factorisation (after a
        converged solve: A there, to within the solve's tolerance). After a solve that took no iteration
        (its start already met the tests: a warm start, a step inside the linear range) there is none
        of this state, and it may be none at all: A is then assembled at the state and factorised once.
        """
        ksp = self.snes.getKSP()
        if not self.jacobian_current:
            self.reduction.restrict(compat.function_vector(self.physics.state), self.x)
            self._jacobian(self.snes, self.x, self.A, self.A)
            ksp.setOperators(self.A, self.A)
        t0 = time.perf_counter()
        ksp.solve(b, x)
        self.timings.linear_solve += time.perf_counter() - t0
        return ksp.getConvergedReason() >= 0 and bool(np.all(np.isfinite(x.getArray(readonly=True))))
