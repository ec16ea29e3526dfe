"""Sensitivities by the direct method: du/dp = -A^-1 dR/dp at a converged state.

R(u; p) = 0 at every converged state, so dR/du du/dp + dR/dp = 0. dR/dp is the residual's exact
partial derivative with respect to the parameter's Constant
(:meth:`~suture_fem.physics.problem.Physics.parameter_derivative`); A = dR/du is the Jacobian. Both
act on the unknowns SNES solves for (u = T x, :class:`~suture_fem.solve.reduction.Reduction`), so the
fixed dofs stay fixed. The calibration's ramps hand the converged Newton solver to their report
callback (:func:`~suture_fem.solve.stepping.ramp` with ``with_solver``), and A's factorisation from
its last iteration (inside the solve's tolerance of the converged state) solves for every parameter
of that state: no assembly, no factorisation, unless the inertia correction shifted that last
factorisation (then A is assembled and factorised once). Callers without a solver (reproduce's USUM
bands, at each state a solved Model reports) get A assembled at the state and factorised once (MUMPS LU).
A is the Newton solver's full Jacobian, the hand-assembled contact and friction terms included
(:mod:`suture_fem.solve.jacobian`). With the cones' augmented Lagrangian the settled state's derivative
holds the pressed nodes on their cones (the multipliers follow the state), which Newton's frozen
multipliers do not: A is then always assembled here (``settled``), one factorisation per state.

From du/dp: the thread end's displacement is a linear functional of u (the same form, evaluated at
du/dp); USUM is max |u_i| over the nodes, whose derivative at its node i* is u_i* . du_i*/dp / |u_i*|; the
tissue's stress measures (:data:`SEQV_CD`, :data:`EPTOEQV_CD`) by a central difference of the output
map along du/dp, no extra solve (:mod:`suture_fem.studies.calibrate.measures`).
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry.regions import MM
from suture_fem.physics.problem import Physics
from suture_fem.scene.schema import OutputSection
from suture_fem.solve import jacobian
from suture_fem.solve.reduction import Reduction
from suture_fem.studies.calibrate.data import EPTOEQV_CD, SEQV_CD, THREAD_END, USUM
from suture_fem.studies.calibrate.measures import TissueMeasures
from suture_fem.support import compat


class Sensitivity:
    """The predictions of one physics and their derivatives with respect to its Constant parameters."""

    def __init__(self, physics: Physics, output: OutputSection | None = None):
        """The reduction, the Jacobian's matrices and the thread-end functional at a displacement change.

        ``output`` (the scene's output section) is needed for the tissue's stress measures only; their
        expressions are compiled at the first use.
        """
        self.physics, self.output = physics, output
        self._measures: TissueMeasures | None = None
        self.reduction = Reduction(physics)
        self.J_form = physics.form("jacobian")
        self.A_full = jacobian.create(physics, self.J_form)  # with room for the nodal terms (contact, friction)
        self.du_state = dolfinx.fem.Function(physics.W)
        self.du = dolfinx.fem.Function(physics.V) if physics.u_in_state is not None else self.du_state
        self.end_form = dolfinx.fem.form(ufl.replace(physics.end_displacement, {physics.u: self.du}))

    def thread_end_mm(self) -> float:
        """The thread end's axial displacement (mm) at the current state."""
        p = self.physics
        return p.comm.allreduce(dolfinx.fem.assemble_scalar(p.form("end_displacement")), op=MPI.SUM) / p.pull_area / MM

    def _thread_end_change(self) -> float:
        p = self.physics
        return p.comm.allreduce(dolfinx.fem.assemble_scalar(self.end_form), op=MPI.SUM) / p.pull_area / MM

    def _usum_node(self) -> tuple[float, np.ndarray, int]:
        """(USUM in mm, the displacement at its node, the node's local index or -1 on other ranks)."""
        u = self.physics.u
        n = u.function_space.dofmap.index_map.size_local
        values = u.x.array.reshape(-1, 2)[:n]
        mags = np.linalg.norm(values, axis=1)
        i = int(np.argmax(mags)) if n else -1
        local = float(mags[i]) if n else -1.0
        best = self.physics.comm.allreduce((local, self.physics.comm.rank), op=MPI.MAXLOC)
        mine = best[1] == self.physics.comm.rank
        return best[0] / MM, values[i].copy() if mine else np.zeros(2), i if mine else -1

    def measures(self) -> TissueMeasures:
        """The tissue's stress measures of this physics (built at the first call)."""
        if self._measures is None:
            if self.output is None:
                raise ValueError("the tissue's stress measures need the scene's output section")
            self._measures = TissueMeasures(self.physics, self.output)
        return self._measures

    def value(self, quantity: str) -> float:
        """The prediction at the current state: :data:`THREAD_END` or :data:`USUM` (mm), a stress measure."""
        if quantity in (SEQV_CD, EPTOEQV_CD):
            return self.measures().maximum(quantity)[0]
        return self.thread_end_mm() if quantity == THREAD_END else self._usum_node()[0]

    def at_state(self, quantity: str, keys: list[str], solver: Any = None) -> tuple[float, np.ndarray]:
        """The prediction and its derivative with respect to every key, at the current (converged) state."""
        values, derivatives, _ = self.at_state_many([quantity], keys, solver)
        return values[0], derivatives[0]

    def at_state_many(self, quantities: list[str], keys: list[str],
                      solver: Any = None) -> tuple[list[float], list[np.ndarray], list[np.ndarray]]:
        """:meth:`at_state` of several quantities at once: one factorisation of the Jacobian for them all.

        Returns (values, their derivatives, du/dp of every key as local arrays of the state).

        ``solver``: the NewtonSolver that just converged (:func:`~suture_fem.solve.stepping.ramp` with
        ``with_solver``), whose factorisation is then reused; None: A is assembled and factorised here.
        """
        values, centres = [], {}
        for quantity in quantities:
            if quantity in (SEQV_CD, EPTOEQV_CD):
                value, centres[quantity] = self.measures().maximum(quantity)
            else:
                value = self.value(quantity)
            values.append(value)
        out = [np.zeros(len(keys)) for _ in quantities]
        if not keys:
            return values, out, []
        changes = self.state_derivatives(keys, solver)
        for j, (key, change) in enumerate(zip(keys, changes)):
            for i, quantity in enumerate(quantities):
                if quantity in centres:
                    out[i][j] = self.measures().derivative(quantity, centres[quantity], key, change)
                else:
                    out[i][j] = self._change_of(quantity, change)
        return values, out, changes

    def _change_of(self, quantity: str, change: np.ndarray) -> float:
        """The prediction's derivative (mm per unit parameter) given du/dp as the state's local array."""
        p = self.physics
        self.du_state.x.array[:] = change
        if p.u_in_state is not None:
            self.du.x.array[:] = change[p.u_in_state]
        if quantity == THREAD_END:
            return self._thread_end_change()
        if quantity != USUM:
            raise ValueError(f"unknown quantity {quantity!r}")
        usum, u_node, i = self._usum_node()
        local = 0.0
        if i >= 0 and usum > 0:
            local = float(u_node @ self.du.x.array.reshape(-1, 2)[i]) / (usum * MM) / MM
        return p.comm.allreduce(local, op=MPI.SUM)

    def state_derivatives(self, keys: list[str], solver: Any = None) -> list[np.ndarray]:
        """Du/dp for every key, as local arrays of the state.

        With ``solver`` (the NewtonSolver that just converged) its factorisation solves A du/dp = -dR/dp
        (no assembly, no factorisation, unless its last one was shifted by the inertia correction); without,
        or with the cones' augmented Lagrangian (:func:`~suture_fem.solve.jacobian.follows_state`), A is
        assembled and factorised once here for every key.
        """
        if solver is not None and not jacobian.follows_state(self.physics):
            return self._derivatives(keys, solver.reduction.T, solver.solve_reduced)
        T = self.reduction.T
        jacobian.assemble(self.physics, self.J_form, self.A_full, settled=True)  # the nodal terms' too
        A = self.A_full.ptap(T)
        ksp = PETSc.KSP().create(self.physics.comm)
        ksp.setOperators(A)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")

        def solve(b: Any, x: Any) -> bool:
            ksp.solve(b, x)
            return ksp.getConvergedReason() >= 0

        try:
            return self._derivatives(keys, T, solve)
        finally:
            ksp.destroy()
            A.destroy()

    def _derivatives(self, keys: list[str], T: Any, solve: Any) -> list[np.ndarray]:
        """Du/dp for every key: -dR/dp on the unknowns, ``solve(b, x)`` (A x = b; False: failed), u = T x."""
        b, x = T.createVecRight(), T.createVecRight()
        out = []
        try:
            for key in keys:
                rhs = dolfinx.fem.petsc.assemble_vector(self.physics.parameter_derivative(key))
                rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                T.multTranspose(rhs, b)
                rhs.destroy()
                b.scale(-1.0)
                if not solve(b, x):
                    raise RuntimeError(f"the sensitivity solve for {key} failed")
                vec = compat.function_vector(self.du_state)
                T.mult(x, vec)
                vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                out.append(self.du_state.x.array.copy())
        finally:
            b.destroy()
            x.destroy()
        return out
