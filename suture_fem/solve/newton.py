"""Newton's method: PETSc SNES (Newton + line search, direct LU) on the reduced unknowns.

SNES solves for x (:class:`~suture_fem.physics.constraints.Unknowns`), the state being u = T x (+ g)
(:class:`~suture_fem.solve.reduction.Reduction`): the residual and Jacobian are T^T R(T x) and T^T A T.

These guards keep hard cases from producing silent wrong numbers or stalling for nothing (the
adaptive load stepping that drives the solver is :mod:`suture_fem.solve.stepping`):

* Admissible domain (:mod:`suture_fem.solve.guard`). Before a residual is assembled the state is checked to be inside
  every material's domain. A trial state outside it is never evaluated into NaN: where petsc4py offers
  ``SNESSetFunctionDomainError`` it is called; on petsc4py 3.18 (which has not) the residual is returned as a huge
  finite vector (:data:`OUTSIDE_DOMAIN_RESIDUAL`), so the backtracking line search rejects the trial and shortens the
  step, and a Newton solve that cannot recover fails cleanly.
* Symmetric factorisation. The Jacobian of a hyperelastic energy is symmetric, and so is T^T A T: a static scene with
  the plain displacement formulation is factorised by MUMPS LDL^T (``pc_type = cholesky``; half the memory of LU, about
  15 % less time per factorisation on the paper scene, benchmarks/speed.py). Mixed pressure rows and
  stiffness-proportional damping are not symmetric; those scenes, and every fallback solver, use LU
  (:func:`~suture_fem.solve.linear.factor_type`).
* Energy line search: :func:`~suture_fem.solve.potential.potential_form`.
* Inertia correction (``solver.inertia_correction``, with LDL^T): a Jacobian with negative pivots is shifted until it
  has none (:mod:`suture_fem.solve.inertia`): the Newton step of a positive definite model, where the indefinite one
  made the line search creep; first, the P2 cones' exact terms where convexified (:func:`.jacobian.exact_kept`).
  Where a solve still fails, a trust region on the energy from its start (:mod:`~suture_fem.solve.trust`).
* Linear solver fallback. When the LU factorisation fails, the next direct solver of :data:`FALLBACK_ORDER` is tried
  for the same step (:meth:`NewtonSolver.next_linear_solver`), and the switch is logged.
* Round-off floor. ``solver.atol`` is an absolute residual norm (N), but the residual of a stiff suture tied into soft
  tissue cannot fall below the rounding of its state: about eps * ||A diag|x| ||_F (A the Jacobian), 7e-10 N for the
  paper scene at 4 N, above the default atol of 1e-10 N, where Newton would stagnate. Each solve uses max(atol, that
  floor) (:meth:`NewtonSolver.round_off_floor`; the run records the largest), and never more than ``BALANCE_TOL`` of
  the force applied at the step: a state is converged only when it balances the pull (:mod:`suture_fem.scene.balance`).
* Line search fallback. The residual norm is a poor merit function where the tissue is nearly incompressible: from rest,
  the backtracking ("bt") line search creeps with steps of a few percent while full Newton steps ("basic") converge
  quadratically; where full steps leave the admissible domain it is the other way round. A Newton solve that fails is
  retried once at the same load with the other line search (:meth:`NewtonSolver.other_line_search`; the stepping keeps
  that one while it works) before the step is cut.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import dolfinx.fem.petsc
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.physics.effects.fixed_point import settle
from suture_fem.physics.effects.friction import full_residual, nodal_terms, slip_laws
from suture_fem.scene.balance import BALANCE_TOL
from suture_fem.scene.schema import SolverSection
from suture_fem.solve import inertia, jacobian, linear
from suture_fem.solve.guard import DomainGuard, Violation
from suture_fem.solve.linearised import Linearised
from suture_fem.solve.memo import IterateMemo
from suture_fem.solve.potential import potential_form
from suture_fem.solve.records import Timings
from suture_fem.solve.reduction import Discrete, Reduction
from suture_fem.solve.stopping import INCREMENT_RTOL, StopTests, force_scale, stall_iterations
from suture_fem.solve.trust import TrustRegion
from suture_fem.support import compat, signals
from suture_fem.support.errors import Interrupted
from suture_fem.support.options import forget_options, forget_when_collected

log = logging.getLogger("suture_fem")

#: Residual entry returned for a state outside the admissible domain (finite, so every PETSc
#: line search can compare it, and larger than any physical residual).
OUTSIDE_DOMAIN_RESIDUAL = 1e30
#: Direct solvers in the order they are tried ("petsc", serial only, last).
FALLBACK_ORDER = ("mumps", "superlu_dist", "petsc")
#: The reason :meth:`NewtonSolver.solve` returns when PETSc raised an error (a failed factorisation
#: raised instead of reported) rather than returning a converged reason.
PETSC_ERROR = "petsc_error"


class NewtonSolver(Linearised):
    """SNES on T^T R(T x + g) and T^T A T, with the domain guard in the residual.

    ``problem`` is a scene's :class:`~suture_fem.physics.problem.Physics` (its guard is then
    :meth:`DomainGuard.of` it) or any :class:`~suture_fem.solve.reduction.Discrete` problem with its
    own ``guard``; ``offset`` is the reduction's g (None: u = T x).
    """

    def __init__(self, problem: Discrete, solver_options: SolverSection, timings: Timings,
                 guard: DomainGuard | None = None, offset: Any = None):
        """Compile the forms and the guard, build the reduction and configure SNES under its own prefix."""
        self.physics = problem
        self.timings = timings
        t0 = time.perf_counter()
        self.F_form = problem.form("residual")
        self.J_form = problem.form("jacobian")
        kept = getattr(problem, "kept", lambda name, build: build())  # a scene's physics keeps them across solves
        self.guard = guard if guard is not None else kept("guard", lambda: DomainGuard.of(problem))
        self.guard.violation = None
        timings.form_compilation += time.perf_counter() - t0
        self.objective_form = kept("objective", lambda: potential_form(problem))
        self.reduction = Reduction(problem, offset)
        self.b_full = dolfinx.fem.petsc.create_vector(self.F_form)
        self.A_full = jacobian.create(problem, self.J_form)
        self.nodal, self.laws = nodal_terms(problem), slip_laws(problem)  # hand-assembled: friction, cone contact
        self._assemble_full_jacobian()
        self.A = self.A_full.ptap(self.reduction.T)
        self.b = self.reduction.create_vector()
        self.x = self.reduction.create_vector()
        self._scaled: Any = None  # work matrix for the round-off floor
        self._work = self.x.duplicate()  # scratch vector of the unknowns
        self.floor = 0.0  # round-off floor of the residual at the start of the last solve that assembled A (N)
        self.outside_domain = 0
        self.inertia_shifts = 0  # Jacobians inertia.correct shifted in the last solve
        self.last_violation: Violation | None = None
        self.memo = IterateMemo(problem.comm)
        self.options = solver_options
        self.linear_solver = solver_options.linear_solver
        self.line_search = str(solver_options.petsc_options.get("snes_linesearch_type", "bt"))
        self.stops = StopTests(lambda: self.objective_form is not None and self.line_search == "bt",
                               lambda: force_scale(self.physics),
                               float(solver_options.petsc_options.get("snes_divergence_tolerance", 1e4)),
                               stall_iterations(problem))
        self.snes = PETSc.SNES().create(problem.comm)
        self.prefix = f"suture_{id(self)}_"
        forget_when_collected(self, self.prefix)  # PETSc 3.18's options database holds 512 entries
        self._configure()
        self.trust = TrustRegion.of(self)  # the fallback where SNES's line search fails (trust.py)

    @classmethod
    def of(cls, physics: Any, solver_options: SolverSection, timings: Timings) -> NewtonSolver:
        """The solver of a scene's physics (under displacement control the end's displacement is the offset)."""
        return cls(physics, solver_options, timings, offset=physics.control.offset if physics.control else None)

    def restart(self, timings: Timings) -> NewtonSolver:
        """This solver, ready to follow a new ramp as one built for it would (a Model keeps its solver).

        Reset: the timings, the floor, the tolerances, the fallbacks' line search and linear solver (a switched
        one's factorisation dropped), the inertia correction's last shift. Kept: the matrices, SNES and the
        factorisation's analysis of the unchanged pattern (measured the same bit for bit, docs/api.md).
        """
        self.timings, self.floor, self.outside_domain, self.inertia_shifts = timings, 0.0, 0, 0
        self.last_violation, self.guard.violation, self.jacobian_current = None, None, False
        ksp = self.snes.getKSP()
        ksp.setAttr(inertia.LAST_SHIFT, None)
        if self.linear_solver != self._configured:
            ksp.getPC().reset()
        self.linear_solver = self.options.linear_solver
        self.line_search = str(self.options.petsc_options.get("snes_linesearch_type", "bt"))
        self._configure()
        return self

    def release(self) -> None:
        """Free the factorisation and its memory; the next Jacobian is analysed and factorised afresh."""
        self.snes.getKSP().getPC().reset()

    def _configure(self) -> None:
        o = self.options
        opts = PETSc.Options()
        base = {
            "snes_type": "newtonls",
            "snes_linesearch_type": self.line_search,
            "snes_max_it": o.max_iterations,
            "snes_rtol": o.rtol,
            "snes_atol": o.atol,
            "snes_stol": INCREMENT_RTOL,
            "snes_max_funcs": 100000,
            "ksp_type": "preonly",
            "pc_type": linear.factor_type(self.physics, self.linear_solver),
            "pc_factor_mat_solver_type": self.linear_solver,
        }
        if self.linear_solver == "mumps":
            base["mat_mumps_icntl_14"] = 200  # extra workspace: stiff suture + soft tissue fill-in
            if o.inertia_correction and self.physics.comm.size > 1:  # the root front's inertia too (inertia.py)
                base["mat_mumps_icntl_13"] = 1
        self.linear_solver = self._configured = linear.configure(o, self, base)  # or a Krylov method with AMG
        base.update({str(k): v for k, v in o.petsc_options.items()})
        if base["pc_type"] == "cholesky":  # MUMPS then reads one triangle of A: declare the symmetry, for good
            self.A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
            self.A.setOption(PETSc.Mat.Option.SYMMETRY_ETERNAL, True)
        self.stol = float(base["snes_stol"])  # the increment test in force (a scene may set its own)
        self.plain_atol: float | None = None  # SNES's absolute test but a fixed point's looser one (None: SNES's)
        self.atol = float(base["snes_atol"])  # the absolute residual test asked for (N)
        for key, value in base.items():
            opts[self.prefix + key] = value
        self.snes.setOptionsPrefix(self.prefix)
        self.snes.setFunction(self._residual, self.b)
        if self.objective_form is not None:
            self.snes.setObjective(self._objective)
            self.snes.setConvergenceTest(self.stops.converged)
        self.snes.setJacobian(self._newton_jacobian, self.A)
        self.snes.setFromOptions()
        self.snes.getKSP().setFromOptions()

    def next_linear_solver(self) -> str | None:
        """Switch to the next direct solver of the fallback order; None when none is left."""
        order = [s for s in FALLBACK_ORDER if s != "petsc" or self.physics.comm.size == 1]
        rest = order[order.index(self.linear_solver) + 1:] if self.linear_solver in order else order
        if not rest:
            return None
        log.warning("linear solver %s failed; falling back to %s", self.linear_solver, rest[0])
        self.linear_solver = rest[0]
        opts = PETSc.Options()
        opts[self.prefix + "pc_factor_mat_solver_type"] = self.linear_solver
        opts[self.prefix + "pc_type"] = "lu"  # the fallbacks factorise with LU
        opts[self.prefix + "ksp_type"] = "preonly"  # after a Krylov method too
        pc = self.snes.getKSP().getPC()
        pc.reset()  # drop the failed factorisation (and its solver type)
        pc.setType("lu")
        pc.setFactorSolverType(self.linear_solver)
        self.snes.getKSP().setFromOptions()
        return self.linear_solver

    def other_line_search(self) -> str:
        """Switch between backtracking and full Newton steps; returns the new line search."""
        self.line_search = "basic" if self.line_search != "basic" else "bt"
        PETSc.Options()[self.prefix + "snes_linesearch_type"] = self.line_search
        self.snes.setFromOptions()
        return self.line_search

    def _trial_admissible(self, x: Any) -> bool:
        """Expand the trial x into the state and check it against the domain guard (counted when outside).

        The guard runs once per iterate of a solve (:mod:`suture_fem.solve.memo`); each call counts.
        """
        self.reduction.expand(x)
        memo = self.memo
        if not memo.at(x) or memo.admissible is None:
            t0 = time.perf_counter()
            memo.admissible, memo.violation = self.guard.admissible(), self.guard.violation
            self.timings.guard += time.perf_counter() - t0
        self.guard.violation = memo.violation
        if not memo.admissible:
            self.outside_domain += 1
            self.last_violation = memo.violation
        return bool(memo.admissible)

    def _residual(self, snes: Any, x: Any, b: Any) -> None:
        signals.check(self.physics.comm)  # a signal (on any rank) ends the solve here, on every rank
        if not self._trial_admissible(x):
            if not compat.set_function_domain_error(snes):
                b.set(OUTSIDE_DOMAIN_RESIDUAL)
            return
        if self.memo.residual is not None:  # this iterate's, computed before in this solve
            b.setArray(self.memo.residual)
            return
        t0 = time.perf_counter()
        self._assemble_full_residual()
        self.reduction.T.multTranspose(self.b_full, b)
        self.memo.keep_residual(b)
        self.timings.assembly += time.perf_counter() - t0

    def _assemble_full_residual(self) -> None:
        """R at the current state into ``b_full`` (owned entries), the nodal terms (friction, contact) included."""
        full_residual(self.physics, self.b_full)

    def _objective(self, snes: Any, x: Any) -> float:
        if not self._trial_admissible(x):
            return OUTSIDE_DOMAIN_RESIDUAL
        if self.memo.potential is None:  # else this iterate's, computed before in this solve
            self.memo.potential = self._potential()
        return self.memo.potential

    def _potential(self) -> float:
        """The objective at the current state, the nodal terms' potential included (collective; timed as assembly)."""
        t0 = time.perf_counter()
        value = float(self.physics.comm.allreduce(dolfinx.fem.assemble_scalar(self.objective_form), op=MPI.SUM))
        for terms in self.nodal:
            value += terms.potential(compat.function_vector(self.physics.state))
        self.timings.assembly += time.perf_counter() - t0
        return value

    def _assemble_full_jacobian(self) -> None:
        jacobian.assemble(self.physics, self.J_form, self.A_full)  # the forms' and the nodal terms' (shared)

    def _jacobian(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        self.jacobian_current = True  # the factorisation SNES makes next is A at this iterate
        self.guard.anchor()  # the line search's trial states start here
        t0 = time.perf_counter()
        self._assemble_full_jacobian()
        self.A_full.ptap(self.reduction.T, A)
        self.timings.assembly += time.perf_counter() - t0
        if snes.getIterationNumber() == 0:  # the state this solve starts from: set its round-off floor
            self.floor = self.round_off_floor(x)
            self.plain_atol = self.absolute_tolerance()
            snes.setTolerances(atol=max(self.plain_atol, self.stops.loose))

    def absolute_tolerance(self) -> float:
        """The residual test (N): ``snes_atol``, at most BALANCE_TOL x the applied force, at least the floor."""
        return max(min(self.atol, BALANCE_TOL * force_scale(self.physics)), self.floor)

    def _newton_jacobian(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        """SNES's Jacobian: :meth:`_jacobian`, then (MUMPS LDL^T) shifted while it has negative pivots."""
        signals.check(self.physics.comm)
        self.factorised = True  # A is factorised before the linear solve (by SNES, or shifted below)
        pc = snes.getKSP().getPC()
        if not (self.options.inertia_correction and pc.getType() == "cholesky" and self.linear_solver == "mumps"):
            return self._jacobian(snes, x, A, P)
        if jacobian.exact_kept(self.physics, lambda: self._jacobian(snes, x, A, P),
                               lambda: inertia.positive_definite(snes.getKSP(), A)):
            return None  # the cones' exact terms with their softening: positive definite (jacobian.py)
        self._jacobian(snes, x, A, P)
        shifted, _ = inertia.correct(snes.getKSP(), A)  # its factorisations count in the linear solve's time
        self.inertia_shifts += shifted
        if shifted:  # the factorisation is not the Jacobian's: a tangent or sensitivity solve assembles A again
            self.jacobian_current = False

    def solve(self) -> tuple[bool, int, str]:
        """One Newton solve from the current state; returns (converged, iterations, reason).

        The reason is the name of SNES's converged reason (e.g. "CONVERGED_FNORM_ABS"), or
        :data:`PETSC_ERROR`. With Coulomb friction, solves until its slip bound settles
        (:func:`~suture_fem.physics.effects.friction.settle`; iterations, domain rejections and inertia shifts
        summed over its solves). ``effort`` judges the step (the stepping grows it when easy): the iterations, but
        the largest solve's where the cones' multipliers are updated, each update a solve however short the step.
        """
        self.outside_domain = self.inertia_shifts = self.largest_solve = 0
        self.factorised = False  # no factorisation of this step's yet (the chord steps need one)
        once = self._solve_once if self.trust is None else self.trust.after(self._solve_once)
        ok, its, reason = settle(self.laws, once, self.absolute_tolerance, self._chord) if self.laws else once()
        self.effort = self.largest_solve if any(getattr(law, "augmented", False) for law in self.laws) else its
        return ok, its, reason

    def _solve_once(self, loose: float = 0.0) -> tuple[bool, int, str]:
        """One SNES solve from the current state (see :meth:`solve`), stopped at |R| <= ``loose`` (N) if above atol."""
        self.stops.loose = loose
        self.reduction.restrict(compat.function_vector(self.physics.state), self.x)
        self.jacobian_current = False
        self.last_violation = None
        t0 = time.perf_counter()
        a0 = self.timings.assembly + self.timings.guard
        plain = self.snes.getTolerances()[1] if self.plain_atol is None else self.plain_atol
        self.plain_atol = min(plain, BALANCE_TOL * force_scale(self.physics))
        self.snes.setTolerances(atol=max(self.plain_atol, loose))
        try:
            with self.memo.open():  # the guard, potential and residual once per iterate (memo.py)
                self.snes.solve(None, self.x)
                its = self.snes.getIterationNumber()
                for _ in range(2):  # go on with the residual tests only (a line-search continuation may hand over)
                    mode = self.stops.finish(self.snes)
                    if mode is None:
                        break
                    its += self._finish(full_steps=mode == "full steps")
        except PETSc.Error as exc:  # a factorisation error raised instead of reported
            if Interrupted.pending is not None:  # a signal inside a PETSc callback: not a solver failure
                raise Interrupted.pending from None
            log.warning("PETSc error during the Newton solve: %s", exc)
            return False, self.snes.getIterationNumber(), PETSC_ERROR
        finally:
            spent = time.perf_counter() - t0
            self.timings.newton_total += spent
            self.timings.linear_solve += spent - (self.timings.assembly + self.timings.guard - a0)
        reason = self.snes.getConvergedReason()
        self.largest_solve = max(self.largest_solve, its)
        self.reduction.expand(self.x)
        finite = bool(np.all(np.isfinite(self.physics.state.x.array)))
        finite = self.physics.comm.allreduce(finite, op=MPI.LAND)
        return reason > 0 and finite, its, _reason_name(reason)

    def _finish(self, full_steps: bool) -> int:
        """Continue from the current iterate with the residual tests only (and full Newton steps); its spent."""
        opts, key = PETSc.Options(), self.prefix + "snes_linesearch_type"
        if full_steps:
            opts[key] = "basic"
            self.snes.setFromOptions()
        self.snes.setTolerances(stol=1e-14)
        self.stops.full_steps = full_steps
        try:
            self.snes.solve(None, self.x)
        finally:
            self.stops.full_steps = False
            if full_steps:
                opts[key] = self.line_search
                self.snes.setFromOptions()
            self.snes.setTolerances(stol=self.stol)
        return self.snes.getIterationNumber()

    def merit(self) -> float:
        """How far the current state is from balance: the potential (with an objective) or |R|; inf outside."""
        if not self.guard.admissible():
            return float("inf")
        if self.objective_form is not None:
            return self._potential()
        t0 = time.perf_counter()
        try:
            self._assemble_full_residual()
            self.reduction.T.multTranspose(self.b_full, self._work)
            return self._work.norm()
        finally:
            self.timings.assembly += time.perf_counter() - t0

    def destroy(self) -> None:
        """Free SNES, its options and every PETSc object of this solver."""
        self.snes.destroy()
        forget_options(self.prefix)  # a later solver in this process (a sweep) may reuse the prefix: leave nothing
        for obj in (self.A, self.A_full, self.b, self.b_full, self.x, self._work, self._scaled):
            if obj is not None:
                obj.destroy()
        self.reduction.destroy()


def _reason_name(reason: int) -> str:
    return {v: k for k, v in PETSc.SNES.ConvergedReason.__dict__.items() if isinstance(v, int)}.get(reason, str(reason))
