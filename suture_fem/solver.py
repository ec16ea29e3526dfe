"""Solver: PETSc SNES (Newton + backtracking line search, direct LU) driving an adaptive load ramp.

Three guards keep hard cases from producing silent wrong numbers:

* Admissible domain. Before a residual is assembled, every quadrature point is checked for J > 0
  and, in Gent regions, I1bar - 3 < Jm. A trial state outside that domain is never evaluated into
  NaN: where petsc4py offers ``SNESSetFunctionDomainError`` it is called; on petsc4py 3.18 (which
  has not) the residual is returned as a huge finite vector, so the backtracking line search rejects
  the trial and shortens the step, and a Newton solve that cannot recover fails cleanly.
* Adaptive load stepping. A step grows when Newton converges in few iterations and is halved and
  retried from the last converged state when it fails; below ``solver.min_step`` the run stops with a
  :class:`~suture_fem.errors.SolveStopped` diagnosis that names the cause.
* Linear solver fallback. When the LU factorisation fails, the next direct solver of the fallback
  list is tried for the same step, and the switch is logged.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
from petsc4py import PETSc

from suture_fem import compat
from suture_fem import mesh as meshmod
from suture_fem.errors import SolveStopped
from suture_fem.physics import REGION_OF_TAG, Physics, quadrature_degree

log = logging.getLogger("suture_fem")

#: Residual entry returned for a state outside the admissible domain (finite, so every PETSc
#: line search can compare it, and larger than any physical residual).
OUTSIDE_DOMAIN_RESIDUAL = 1e30
FALLBACK_ORDER = ("mumps", "superlu_dist", "petsc")


@dataclass
class Timings:
    """Seconds spent in each part of a solve."""

    assembly: float = 0.0
    linear_solve: float = 0.0
    guard: float = 0.0
    form_compilation: float = 0.0
    newton_total: float = 0.0

    def as_dict(self) -> dict[str, float]:
        return {k: round(v, 4) for k, v in self.__dict__.items()}


class DomainGuard:
    """Evaluates each material's limits (J > 0, Gent margin > 0) at the quadrature points.

    The last violation found is kept in ``violation`` (region, quantity, value, location in mm).
    """

    def __init__(self, physics: Physics):
        self.physics = physics
        mesh = physics.mesh
        points = compat.quadrature_points("triangle", quadrature_degree(physics.degree))
        self.checks: list[tuple[str, str, Any, np.ndarray]] = []
        self._x = compat.expression(physics.x, points)
        for tag, region in REGION_OF_TAG.items():
            cells = meshmod.region_cells(physics.tagged, tag)
            for name, expr in physics.materials[region].limits(physics.F).items():
                self.checks.append((region, name, compat.expression(expr, points), cells))
        self.violation: dict[str, Any] | None = None
        self.n_points = len(points)

    def margins(self) -> dict[tuple[str, str], tuple[float, Any]]:
        """Smallest value of each limit on this rank (with its location), before any reduction."""
        out: dict[tuple[str, str], tuple[float, Any]] = {}
        mesh = self.physics.mesh
        for region, name, expr, cells in self.checks:
            if len(cells) == 0:
                continue
            vals = compat.eval_expression(expr, mesh, cells).reshape(len(cells), -1)
            k = int(np.argmin(vals))
            if (region, name) not in out or vals.flat[k] < out[(region, name)][0]:
                out[(region, name)] = (float(vals.flat[k]), (cells[k // vals.shape[1]], k % vals.shape[1]))
        return out

    def admissible(self) -> bool:
        """True on every rank when the current state is inside the domain everywhere (collective)."""
        worst: tuple[float, str, str, Any] | None = None
        for (region, name), (value, where) in self.margins().items():
            if not math.isfinite(value) or value <= 0.0:
                if worst is None or value < worst[0] or not math.isfinite(value):
                    worst = (value, region, name, where)
        local = None
        if worst is not None:
            value, region, name, (cell, ip) = worst
            xy = compat.eval_expression(self._x, self.physics.mesh, np.array([cell], dtype=np.int32))
            xy = xy.reshape(-1, 2)[ip] / meshmod.MM
            local = {"region": region, "quantity": name, "value": value, "r_mm": float(xy[0]), "z_mm": float(xy[1])}
        found = [v for v in self.physics.comm.allgather(local) if v is not None]
        self.violation = min(found, key=lambda v: v["value"]) if found else None
        return self.violation is None


class NewtonSolver:
    """SNES on the physics' residual and Jacobian, with the domain guard in the residual."""

    def __init__(self, physics: Physics, solver_options: dict[str, Any], timings: Timings):
        self.physics = physics
        self.timings = timings
        t0 = time.perf_counter()
        self.F_form = physics.form("residual")
        self.J_form = physics.form("jacobian")
        self.guard = DomainGuard(physics)
        timings.form_compilation += time.perf_counter() - t0
        self.b = dolfinx.fem.petsc.create_vector(self.F_form)
        self.A = dolfinx.fem.petsc.create_matrix(self.J_form)
        self.x = compat.function_vector(physics.u).copy()
        self.outside_domain = 0
        self.last_violation: dict[str, Any] | None = None
        self.options = solver_options
        self.linear_solver = solver_options["linear_solver"]
        self.snes = PETSc.SNES().create(physics.comm)
        self.prefix = f"suture_{id(self)}_"
        self._configure()

    def _configure(self) -> None:
        o = self.options
        opts = PETSc.Options()
        base = {
            "snes_type": "newtonls",
            "snes_linesearch_type": "bt",
            "snes_max_it": o["max_iterations"],
            "snes_rtol": o["rtol"],
            "snes_atol": o["atol"],
            "snes_stol": 1e-14,
            "snes_max_funcs": 100000,
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": self.linear_solver,
        }
        if self.linear_solver == "mumps":
            base["mat_mumps_icntl_14"] = 200  # extra workspace: stiff suture + soft tissue fill-in
        base.update({str(k): v for k, v in o.get("petsc_options", {}).items()})
        for key, value in base.items():
            opts[self.prefix + key] = value
        self.snes.setOptionsPrefix(self.prefix)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A)
        self.snes.setFromOptions()
        self.snes.getKSP().setFromOptions()

    def next_linear_solver(self) -> str | None:
        """Switch to the next direct solver of the fallback order; None when none is left."""
        order = [s for s in FALLBACK_ORDER if s != "petsc" or self.physics.comm.size == 1]
        rest = order[order.index(self.linear_solver) + 1:] if self.linear_solver in order else []
        if not rest:
            return None
        log.warning("linear solver %s failed; falling back to %s", self.linear_solver, rest[0])
        self.linear_solver = rest[0]
        opts = PETSc.Options()
        opts[self.prefix + "pc_factor_mat_solver_type"] = self.linear_solver
        self.snes.getKSP().getPC().setFactorSolverType(self.linear_solver)
        self.snes.getKSP().setFromOptions()
        return self.linear_solver

    def _update_state(self, x: Any) -> None:
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(compat.function_vector(self.physics.u))
        self.physics.u.x.scatter_forward()

    def _residual(self, snes: Any, x: Any, b: Any) -> None:
        self._update_state(x)
        t0 = time.perf_counter()
        ok = self.guard.admissible()
        self.timings.guard += time.perf_counter() - t0
        if not ok:
            self.outside_domain += 1
            self.last_violation = self.guard.violation
            if not compat.set_function_domain_error(snes):
                b.set(OUTSIDE_DOMAIN_RESIDUAL)
            return
        t0 = time.perf_counter()
        with b.localForm() as b_local:
            b_local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self.F_form)
        dolfinx.fem.petsc.apply_lifting(b, [self.J_form], bcs=[self.physics.bcs], x0=[x], scale=-1.0)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        dolfinx.fem.petsc.set_bc(b, self.physics.bcs, x, -1.0)
        self.timings.assembly += time.perf_counter() - t0

    def _jacobian(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        t0 = time.perf_counter()
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, self.J_form, bcs=self.physics.bcs)
        A.assemble()
        self.timings.assembly += time.perf_counter() - t0

    def solve(self) -> tuple[bool, int, str]:
        """One Newton solve from the current state; returns (converged, iterations, reason)."""
        compat.function_vector(self.physics.u).copy(self.x)
        self.outside_domain = 0
        self.last_violation = None
        t0 = time.perf_counter()
        a0 = self.timings.assembly + self.timings.guard
        try:
            self.snes.solve(None, self.x)
        except PETSc.Error as exc:  # a factorisation error raised instead of reported
            log.warning("PETSc error during the Newton solve: %s", exc)
            return False, self.snes.getIterationNumber(), "petsc_error"
        finally:
            spent = time.perf_counter() - t0
            self.timings.newton_total += spent
            self.timings.linear_solve += spent - (self.timings.assembly + self.timings.guard - a0)
        reason = self.snes.getConvergedReason()
        its = self.snes.getIterationNumber()
        self._update_state(self.x)
        finite = bool(np.all(np.isfinite(self.physics.u.x.array)))
        finite = self.physics.comm.allreduce(finite, op=_MPI_LAND())
        return reason > 0 and finite, its, _reason_name(reason)

    def linear_failure(self) -> bool:
        return self.snes.getKSP().getConvergedReason() < 0

    def residual_norm(self) -> float:
        return self.snes.getFunctionNorm()

    def destroy(self) -> None:
        self.snes.destroy()
        self.A.destroy()
        self.b.destroy()
        self.x.destroy()


def _MPI_LAND() -> Any:
    from mpi4py import MPI

    return MPI.LAND


def _reason_name(reason: int) -> str:
    names = {v: k for k, v in PETSc.SNES.ConvergedReason.__dict__.items() if isinstance(v, int)}
    return names.get(reason, str(reason))


@dataclass
class StepRecord:
    force_n: float
    iterations: int
    step: float


@dataclass
class RampResult:
    """What the load ramp did."""

    steps: list[StepRecord] = field(default_factory=list)
    cutbacks: int = 0
    newton_iterations: int = 0
    linear_solver: str = ""
    fallbacks: list[str] = field(default_factory=list)
    timings: Timings = field(default_factory=Timings)


def ramp(
    physics: Physics,
    scene: dict[str, Any],
    on_converged: Callable[[float, bool], None],
    timings: Timings | None = None,
) -> RampResult:
    """Ramp the force from 0 to ``loading.force_n`` with adaptive steps.

    ``on_converged(force_n, is_report_point)`` is called after every converged step; report points
    (``loading.report_forces_n`` and the peak) are always hit exactly.
    Raises SolveStopped (with every converged step already handed to on_converged) when it cannot go on.
    """
    o = scene["solver"]
    f_max = scene["loading"]["force_n"]
    targets = sorted(set(f / f_max for f in scene["loading"]["report_forces_n"]) | {1.0})
    result = RampResult(timings=timings or Timings())
    newton = NewtonSolver(physics, o, result.timings)
    result.linear_solver = newton.linear_solver
    u_vec = compat.function_vector(physics.u)
    last = u_vec.copy()
    previous: Any = None  # state before `last`, for the linear predictor
    lam, prev_step, step = 0.0, 0.0, o["initial_step"]
    try:
        while lam < 1.0 - 1e-12:
            target = next(t for t in targets if t > lam + 1e-12)
            trial = min(lam + step, target)
            if target - trial < o["min_step"]:
                trial = target
            if previous is not None and prev_step > 0:  # linear predictor from the last two states
                u_vec.axpy((trial - lam) / prev_step, last - previous)
                physics.u.x.scatter_forward()
                if not newton.guard.admissible():
                    last.copy(u_vec)
                    physics.u.x.scatter_forward()
            physics.set_force(trial * f_max)
            ok, its, reason = newton.solve()
            result.newton_iterations += its
            if ok:
                if previous is None:
                    previous = last.copy()
                else:
                    last.copy(previous)
                u_vec.copy(last)
                prev_step = trial - lam
                lam = trial
                hit = any(abs(lam - t) < 1e-12 for t in targets)
                result.steps.append(StepRecord(lam * f_max, its, prev_step))
                log.info(
                    "step %3d  F = %8.4f N (%5.1f %%)  Newton its %2d  |R| %.2e  cutbacks %d",
                    len(result.steps), lam * f_max, 100 * lam, its, newton.residual_norm(), result.cutbacks,
                )
                on_converged(lam * f_max, hit)
                if its <= o["easy_iterations"]:
                    step = min(step * o["grow"], o["max_step"])
                continue
            last.copy(u_vec)
            physics.u.x.scatter_forward()
            if newton.linear_failure() or reason == "petsc_error":
                fallback = newton.next_linear_solver()
                if fallback is not None:
                    result.fallbacks.append(fallback)
                    result.linear_solver = fallback
                    continue
            result.cutbacks += 1
            step = 0.5 * (trial - lam)
            why = _diagnose(newton, reason, its)
            log.warning("step to F = %.4f N failed (%s); cutting the step to %.3g", trial * f_max, why, step)
            if step < o["min_step"]:
                raise SolveStopped.with_history(result,
                    cause=_cause(newton, reason),
                    load_reached=lam * f_max,
                    attempted=trial * f_max,
                    detail=f"load step fell below solver.min_step = {o['min_step']:g} after "
                    f"{result.cutbacks} cutbacks; last failure: {why}",
                )
    finally:
        u_vec_final = compat.function_vector(physics.u)
        last.copy(u_vec_final)  # never leave a diverged state behind
        physics.u.x.scatter_forward()
        newton.destroy()
    return result


def _cause(newton: NewtonSolver, reason: str) -> str:
    if newton.last_violation is not None:
        v = newton.last_violation
        return "gent_limit" if v["quantity"].startswith("Gent") else "inverted_element"
    if newton.linear_failure():
        return "linear_solver"
    return "newton_divergence"


def _diagnose(newton: NewtonSolver, reason: str, its: int) -> str:
    text = f"SNES {reason} after {its} iterations"
    v = newton.last_violation
    if v is not None:
        what = "J <= 0" if v["quantity"] == "J" else "Gent limit I1bar - 3 >= Jm"
        text += (
            f"; trial states left the admissible domain {newton.outside_domain} times ({what} in the "
            f"{v['region']} at r = {v['r_mm']:.3f} mm, z = {v['z_mm']:.3f} mm, value {v['value']:.3g})"
        )
    if newton.linear_failure():
        text += f"; linear solver {newton.linear_solver} failed"
    return text
