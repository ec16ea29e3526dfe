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
from mpi4py import MPI
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
    #: set when a Newton iteration of the current step factorised a Jacobian (shifted or not)
    factorised: bool = False

    def load_rate(self, set_load: Any, s: float, step: float = 1.0) -> Any:
        """-dR/ds on the unknowns (a new vector), ``set_load(v)`` setting the loads at path parameter v.

        The pull and the weight are dead loads, linear in s: (R(u, s + 1) - R(u, s)) is dR/ds at every u
        (``step`` 1). A prescribed displacement is not: a small ``step`` gives its forward difference.
        """
        r0, r1 = self.b.duplicate(), self.b.duplicate()
        try:
            set_load(s + step)
            self._residual(self.snes, self.x, r1)
            set_load(s)
            self._residual(self.snes, self.x, r0)
            r1.axpy(-1.0, r0)
            r1.scale(-1.0 / step)
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

    def _chord(self) -> bool:
        """One chord step of a Coulomb bound's fixed point: x -= A_k^{-1} R(x), A_k the last factorisation (collective).

        After the bound moved, the state is corrected without a new Jacobian (the frozen-bound Jacobian barely
        depends on the bound); the fixed point's last solve is a full Newton solve. False (the state left as
        it was) where no solve of this step has factorised yet, or the step leaves the admissible domain.
        """
        if not self.factorised:
            return False
        t0 = time.perf_counter()
        rhs, dx = self._work, self.x.duplicate()
        try:
            self.reduction.restrict(compat.function_vector(self.physics.state), self.x)
            self.reduction.expand(self.x)
            self.guard.anchor()
            self._assemble_full_residual()
            self.reduction.T.multTranspose(self.b_full, rhs)
            t1 = time.perf_counter()
            self.timings.assembly += t1 - t0
            self.snes.getKSP().solve(rhs, dx)
            self.timings.linear_solve += time.perf_counter() - t1
            self.x.axpy(-1.0, dx)
            self.reduction.expand(self.x)
            ok = bool(np.all(np.isfinite(self.physics.state.x.array))) and self.guard.admissible()
            ok = bool(self.physics.comm.allreduce(ok, op=MPI.LAND))
            if not ok:
                self.x.axpy(1.0, dx)
                self.reduction.expand(self.x)
            return ok
        finally:
            dx.destroy()
            self.timings.newton_total += time.perf_counter() - t0

    def linear_failure(self) -> bool:
        """True when the last linear solve failed (e.g. a factorisation that ran out of memory)."""
        return self.snes.getKSP().getConvergedReason() < 0

    def residual_norm(self) -> float:
        """The norm of the reduced residual at the end of the last solve (N)."""
        return self.snes.getFunctionNorm()

    def round_off_floor(self, x: Any) -> float:
        """Eps * ||A diag|x| ||_F: how much rounding each unknown by one ulp changes the residual (N).

        A is the Jacobian last assembled, at x. :meth:`_jacobian` calls this with the first Jacobian of
        each solve, at the state the solve starts from (never at a later iterate, which may be far
        off); the floor then holds for that solve's iterations, and its first residual test (made
        before any Jacobian) uses the previous solve's floor. With random rounding signs this is the
        expected norm of the change; Newton iterates stagnate at about a third of it. A prescribed
        displacement (the reduction's offset g) is rounded too: eps ||A_full diag|g| ||_F is added in
        quadrature (every row of the full Jacobian counted: an upper bound).
        """
        self._work.setArray(np.abs(x.getArray(readonly=True)))
        if self._scaled is None:
            self._scaled = self.A.duplicate(copy=True)
        else:
            self.A.copy(self._scaled, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._scaled.diagonalScale(None, self._work)
        norm = self._scaled.norm(PETSc.NormType.FROBENIUS)
        offset = self.reduction.offset
        if offset is not None:
            g = offset.copy()
            g.abs()
            scaled = self.A_full.duplicate(copy=True)
            scaled.diagonalScale(None, g)
            norm = float(np.hypot(norm, scaled.norm(PETSc.NormType.FROBENIUS)))
            scaled.destroy()
            g.destroy()
        return float(np.finfo(float).eps * norm)
