"""Solver: PETSc SNES (Newton + backtracking line search, direct LU) driving an adaptive load path.

SNES solves for x, the unknowns of :class:`~suture_fem.physics.Unknowns`, with the state u = T x
(:class:`Reduction`): T injects the free dofs and, with a rigid suture, copies the one rigid axial
motion d onto every axial suture dof. The residual and Jacobian are T^T R(T x) and T^T A T (PETSc
PtAP), so the Dirichlet conditions (all zero) and the rigid constraint need no special rows.

These guards keep hard cases from producing silent wrong numbers or stalling for nothing:

* Admissible domain. Before a residual is assembled, every quadrature point is checked for J > 0
  and, in Gent regions, I1bar - 3 < Jm. A trial state outside that domain is never evaluated into
  NaN: where petsc4py offers ``SNESSetFunctionDomainError`` it is called; on petsc4py 3.18 (which
  has not) the residual is returned as a huge finite vector, so the backtracking line search rejects
  the trial and shortens the step, and a Newton solve that cannot recover fails cleanly. A converged
  state is also checked against the physical limit ``solver.gent_limit_fraction``: Gent's energy
  only blows up at I1bar - 3 = Jm, so "the limit is reached" means (I1bar - 3) / Jm >= that fraction
  somewhere (a state there is rejected like a failed step).
* Adaptive load stepping. A step grows when Newton converges in few iterations and is halved and
  retried from the last converged state when it fails; below ``solver.min_step`` the run stops with a
  :class:`~suture_fem.errors.SolveStopped` diagnosis that names the cause.
* Linear solver fallback. When the LU factorisation fails, the next direct solver of the fallback
  list is tried for the same step, and the switch is logged.
* Round-off floor. ``solver.atol`` is an absolute residual norm (N), but the residual of a stiff
  suture tied into soft tissue cannot be driven below the rounding of the state it is evaluated at:
  rounding every unknown by one unit in the last place changes R by about eps * ||A diag|x| ||_F
  (A the Jacobian), 7e-10 N for the paper scene at 4 N, above the default atol of 1e-10 N. Newton
  then stagnates there and a step whose relative test cannot help (the small increments of a time
  history) fails for nothing. Each solve therefore uses max(atol, that floor) as its absolute
  tolerance, and the run records the largest floor it used.
* Line search fallback. The residual norm is a poor merit function where the tissue is nearly
  incompressible: from rest, the backtracking ("bt") line search creeps with steps of a few percent
  while full Newton steps ("basic") converge quadratically; where full steps leave the admissible
  domain it is the other way round. A Newton solve that fails is retried once at the same load with
  the other line search (and that one is kept while it works) before the step is cut.

The load path is the load fraction (quasi-static), or time over ramp and hold (with inertia); with
gravity the weight is applied first, quasi-statically, at zero pull force.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.physics.problem import FREE, REGION_OF_TAG, RIGID, Physics, quadrature_degree
from suture_fem.scene.model import Scene
from suture_fem.scene.schema import SolverSection
from suture_fem.support import compat
from suture_fem.support.errors import SolveStopped

log = logging.getLogger("suture_fem")

#: Residual entry returned for a state outside the admissible domain (finite, so every PETSc
#: line search can compare it, and larger than any physical residual).
OUTSIDE_DOMAIN_RESIDUAL = 1e30
FALLBACK_ORDER = ("mumps", "superlu_dist", "petsc")
GENT_LIMIT = "Gent limit Jm - (I1bar - 3)"


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
        points = compat.quadrature_points("triangle", quadrature_degree(physics.degree))
        self.checks: list[tuple[str, str, Any, np.ndarray]] = []
        self._x = compat.expression(physics.x, points)
        for tag, region in REGION_OF_TAG.items():
            if region == "suture" and physics.effects.rigid:
                continue  # a rigid translation cannot invert
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

    def _worst(self, offending: Callable[[str, str, float], float | None]) -> dict[str, Any] | None:
        """The most offending point over all ranks (collective); offending() returns a badness or None."""
        worst: tuple[float, str, str, float, Any] | None = None
        for (region, name), (value, where) in self.margins().items():
            bad = offending(region, name, value)
            if bad is not None and (worst is None or bad > worst[0]):
                worst = (bad, region, name, value, where)
        local = None
        if worst is not None:
            bad, region, name, value, (cell, ip) = worst
            xy = compat.eval_expression(self._x, self.physics.mesh, np.array([cell], dtype=np.int32))
            xy = xy.reshape(-1, 2)[ip] / regions.MM
            local = {"region": region, "quantity": name, "value": value, "badness": bad,
                     "r_mm": float(xy[0]), "z_mm": float(xy[1])}
        found = [v for v in self.physics.comm.allgather(local) if v is not None]
        return max(found, key=lambda v: v["badness"]) if found else None

    def admissible(self) -> bool:
        """True on every rank when the current state is inside the domain everywhere (collective)."""

        def outside(region: str, name: str, value: float) -> float | None:
            if name == "J" and not value > 0.0:
                return math.inf  # an inverted element is the root cause (the other limits are NaN there)
            if not math.isfinite(value):
                return 1e300
            return -value if value <= 0.0 else None

        self.violation = self._worst(outside)
        return self.violation is None

    def limit_reached(self, fraction: float) -> dict[str, Any] | None:
        """Where (I1bar - 3) / Jm >= fraction in a Gent region (collective), else None."""

        def used(region: str, name: str, value: float) -> float | None:
            if name != GENT_LIMIT:
                return None
            usage = 1.0 - value / self.physics.materials[region].jm
            return usage if usage >= fraction else None

        found = self._worst(used)
        if found is not None:
            found["limit"] = f"(I1bar - 3) / Jm = {found['badness']:.4f} >= solver.gent_limit_fraction = {fraction:g}"
        return found


class Reduction:
    """u = T x between the state's dofs and the unknowns SNES solves for (see the module docstring)."""

    def __init__(self, physics: Physics):
        comm = physics.comm
        un = physics.unknowns
        W = physics.W
        bs = W.dofmap.index_map_bs
        im = W.dofmap.index_map
        kind = un.kind[: un.n_owned]
        free = np.flatnonzero(kind == FREE)
        rigid = np.flatnonzero(kind == RIGID)
        n_free = len(free)
        offset = comm.exscan(n_free) or 0
        n_free_global = comm.allreduce(n_free)
        holds_d = un.rigid and comm.rank == comm.size - 1
        self.d_owner = comm.size - 1 if un.rigid else None
        n_cols = n_free + (1 if holds_d else 0)
        self.n_global = n_free_global + (1 if un.rigid else 0)
        col = np.full(un.n_owned, -1, dtype=PETSc.IntType)
        col[free] = offset + np.arange(n_free)
        col[rigid] = n_free_global  # d is the last unknown
        has = col >= 0
        indptr = np.concatenate([[0], np.cumsum(has)]).astype(PETSc.IntType)
        self.T = PETSc.Mat().createAIJ(
            size=((un.n_owned, im.size_global * bs), (n_cols, self.n_global)),
            csr=(indptr, col[has], np.ones(int(has.sum()))),
            comm=comm,
        )
        self.T.assemble()
        self.counts = self.T.createVecRight()
        ones = self.T.createVecLeft()
        ones.set(1.0)
        self.T.multTranspose(ones, self.counts)
        ones.destroy()
        self.physics = physics

    def create_vector(self) -> Any:
        return self.T.createVecRight()

    def restrict(self, u_vec: Any, x: Any) -> None:
        """X from a state u that satisfies the constraints (the mean over each column's dofs)."""
        self.T.multTranspose(u_vec, x)
        x.pointwiseDivide(x, self.counts)

    def expand(self, x: Any) -> None:
        """The state u = T x (ghosts updated, displacement view synced)."""
        u_vec = compat.function_vector(self.physics.state)
        self.T.mult(x, u_vec)
        u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.physics.sync()
        if self.d_owner is not None:  # the rigid suture's axial motion, for its boundary condition
            comm = self.physics.comm
            d = x.getArray(readonly=True)[-1] if comm.rank == self.d_owner else None
            self.physics.rigid_displacement.value = comm.bcast(d, root=self.d_owner)

    def destroy(self) -> None:
        self.T.destroy()
        self.counts.destroy()


class NewtonSolver:
    """SNES on T^T R(T x) and T^T A T, with the domain guard in the residual."""

    def __init__(self, physics: Physics, solver_options: SolverSection, timings: Timings):
        self.physics = physics
        self.timings = timings
        t0 = time.perf_counter()
        self.F_form = physics.form("residual")
        self.J_form = physics.form("jacobian")
        self.guard = DomainGuard(physics)
        timings.form_compilation += time.perf_counter() - t0
        self.reduction = Reduction(physics)
        self.b_full = dolfinx.fem.petsc.create_vector(self.F_form)
        self.A_full = dolfinx.fem.petsc.create_matrix(self.J_form)
        self._assemble_full_jacobian()
        self.A = self.A_full.ptap(self.reduction.T)
        self.b = self.reduction.create_vector()
        self.x = self.reduction.create_vector()
        self._scaled: Any = None  # work matrix for the round-off floor
        self._abs_x = self.x.duplicate()
        self.floor = 0.0  # round-off floor of the residual at the start of the last solve that assembled A (N)
        self.outside_domain = 0
        self.last_violation: dict[str, Any] | None = None
        self.options = solver_options
        self.linear_solver = solver_options.linear_solver
        self.line_search = str(solver_options.petsc_options.get("snes_linesearch_type", "bt"))
        self.snes = PETSc.SNES().create(physics.comm)
        self.prefix = f"suture_{id(self)}_"
        self._configure()

    def _configure(self) -> None:
        o = self.options
        opts = PETSc.Options()
        base = {
            "snes_type": "newtonls",
            "snes_linesearch_type": self.line_search,
            "snes_max_it": o.max_iterations,
            "snes_rtol": o.rtol,
            "snes_atol": o.atol,
            "snes_stol": 1e-14,
            "snes_max_funcs": 100000,
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": self.linear_solver,
        }
        if self.linear_solver == "mumps":
            base["mat_mumps_icntl_14"] = 200  # extra workspace: stiff suture + soft tissue fill-in
        base.update({str(k): v for k, v in o.petsc_options.items()})
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

    def _residual(self, snes: Any, x: Any, b: Any) -> None:
        self.reduction.expand(x)
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
        with self.b_full.localForm() as b_local:
            b_local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(self.b_full, self.F_form)
        self.b_full.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.reduction.T.multTranspose(self.b_full, b)
        self.timings.assembly += time.perf_counter() - t0

    def _assemble_full_jacobian(self) -> None:
        self.A_full.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(self.A_full, self.J_form)
        self.A_full.assemble()

    def _jacobian(self, snes: Any, x: Any, A: Any, P: Any) -> None:
        t0 = time.perf_counter()
        self._assemble_full_jacobian()
        self.A_full.ptap(self.reduction.T, A)
        self.timings.assembly += time.perf_counter() - t0
        if snes.getIterationNumber() == 0:  # the state this solve starts from: set its round-off floor
            self.floor = self.round_off_floor(x)
            snes.setTolerances(atol=max(self.options.atol, self.floor))

    def round_off_floor(self, x: Any) -> float:
        """Eps * ||A diag|x| ||_F: how much rounding each unknown by one ulp changes the residual (N).

        A is the Jacobian last assembled, at x. :meth:`_jacobian` calls this with the first Jacobian of
        each solve, at the state the solve starts from (never at a later iterate, which may be far
        off); the floor then holds for that solve's iterations, and its first residual test (made
        before any Jacobian) uses the previous solve's floor. With random rounding signs this is the
        expected norm of the change; Newton iterates stagnate at about a third of it.
        """
        self._abs_x.setArray(np.abs(x.getArray(readonly=True)))
        if self._scaled is None:
            self._scaled = self.A.duplicate(copy=True)
        else:
            self.A.copy(self._scaled, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._scaled.diagonalScale(None, self._abs_x)
        return float(np.finfo(float).eps * self._scaled.norm(PETSc.NormType.FROBENIUS))

    def solve(self) -> tuple[bool, int, str]:
        """One Newton solve from the current state; returns (converged, iterations, reason)."""
        self.reduction.restrict(compat.function_vector(self.physics.state), self.x)
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
        self.reduction.expand(self.x)
        finite = bool(np.all(np.isfinite(self.physics.state.x.array)))
        finite = self.physics.comm.allreduce(finite, op=_MPI_LAND())
        return reason > 0 and finite, its, _reason_name(reason)

    def linear_failure(self) -> bool:
        return self.snes.getKSP().getConvergedReason() < 0

    def residual_norm(self) -> float:
        return self.snes.getFunctionNorm()

    def destroy(self) -> None:
        self.snes.destroy()
        opts = PETSc.Options()  # a later solver in this process (a sweep) may reuse the prefix: leave nothing
        for key in [k for k in opts.getAll() if k.startswith(self.prefix)]:
            opts.delValue(key)
        for obj in (self.A, self.A_full, self.b, self.b_full, self.x, self._abs_x, self._scaled):
            if obj is not None:
                obj.destroy()
        self.reduction.destroy()


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
    line_search_switches: int = 0
    #: largest round-off floor of the residual (N) used as the absolute tolerance, and in how many solves
    #: it was above ``solver.atol``
    residual_floor_n: float = 0.0
    floor_above_atol: int = 0
    unknowns: int = 0
    timings: Timings = field(default_factory=Timings)


class Path:
    """A parameter s the run steps along, from 0 to ``targets[-1]``, hitting every target exactly."""

    label = "load"
    reports = True

    def __init__(self, physics: Physics, targets: list[float], initial: float, min_step: float, max_step: float,
                 grow: float):
        self.physics = physics
        self.targets, self.initial, self.min_step, self.max_step, self.grow = targets, initial, min_step, max_step, grow
        self.end = targets[-1]

    def force(self, s: float) -> float:
        raise NotImplementedError

    def apply(self, s_from: float, s_to: float) -> None:
        """Set the loads (and time step) of a trial from s_from to s_to."""
        self.physics.set_force(self.force(s_to))

    def accept(self, s_from: float, s_to: float) -> None:
        """After a converged and reported step."""

    def restore(self, s: float) -> None:
        """Loads of the converged state at s (after a failed trial, e.g. when the path stops)."""
        self.physics.set_force(self.force(s))

    def before_report(self, s: float) -> None:
        """After a converged step, before its outputs are evaluated."""

    def time(self, s: float) -> float | None:
        return None

    def describe(self, s: float) -> str:
        return f"F = {self.force(s):8.4f} N ({100 * s / self.end:5.1f} %)"


class LoadRamp(Path):
    """Quasi-static: s is the fraction of ``loading.force_n``."""

    def __init__(self, physics: Physics, scene: Scene):
        o, f_max = scene.solver, scene.loading.force_n
        self.f_max = f_max
        targets = sorted(set(f / f_max for f in scene.loading.report_forces_n) | {1.0})
        super().__init__(physics, targets, o.initial_step, o.min_step, o.max_step, o.grow)

    def force(self, s: float) -> float:
        return s * self.f_max


class GravityPreload(Path):
    """The weight, ramped from 0 to 1 at zero pull force, before the pull (no reports)."""

    label = "gravity"
    reports = False

    def __init__(self, physics: Physics, scene: Scene):
        o = scene.solver
        super().__init__(physics, [1.0], 1.0, o.min_step, 1.0, o.grow)

    def force(self, s: float) -> float:
        return 0.0

    def apply(self, s_from: float, s_to: float) -> None:
        self.physics.set_force(0.0)
        self.physics.gravity_factor.value = s_to

    def restore(self, s: float) -> None:
        self.apply(s, s)

    def describe(self, s: float) -> str:
        return f"gravity {100 * s:5.1f} %"


class TimeHistory(Path):
    """Inertia: s is time; the force ramps over ``loading.ramp_s`` and is held for ``loading.hold_s``."""

    label = "time"

    def __init__(self, physics: Physics, scene: Scene):
        load, o = scene.loading, scene.solver
        self.f_max, self.ramp_s = load.force_n, load.ramp_s
        dt = scene.effects.time_step_s
        targets = {f / self.f_max * self.ramp_s for f in load.report_forces_n} | {self.ramp_s}
        if load.hold_s > 0:
            targets.add(self.ramp_s + load.hold_s)
        super().__init__(physics, sorted(targets), dt, o.min_step * self.ramp_s, dt, o.grow)
        self.dynamics = physics.dynamics

    def force(self, t: float) -> float:
        return self.f_max * min(t / self.ramp_s, 1.0)

    def apply(self, t_from: float, t_to: float) -> None:
        af = self.dynamics.scheme.alpha_f
        self.dynamics.dt.value = t_to - t_from
        self.physics.set_force((1 - af) * self.force(t_to) + af * self.force(t_from))

    def accept(self, t_from: float, t_to: float) -> None:
        self.dynamics.accept(self.physics.state)

    def before_report(self, t: float) -> None:
        # with generalized-alpha the step was solved with the force at t_{n+1-alpha_f}; report the force at t
        # (the pulled-face entries of the record's free residual then carry alpha_f times the step's force change)
        self.physics.set_force(self.force(t))

    def time(self, s: float) -> float | None:
        return s

    def describe(self, t: float) -> str:
        return f"t = {t:8.4f} s  F = {self.force(t):8.4f} N"


def ramp(
    physics: Physics,
    scene: Scene,
    on_converged: Callable[..., None],
    timings: Timings | None = None,
) -> RampResult:
    """Follow the scene's load path: gravity preload (if called), then the load ramp or the time history.

    ``on_converged(force_n, is_report_point)`` is called after every converged step of the pull
    (with inertia also ``time_s=t``); report points (``loading.report_forces_n``, the peak and, with
    inertia, the end of the hold) are always hit exactly.
    Raises SolveStopped (with every converged step already handed to on_converged) when it cannot go on.
    """
    result = RampResult(timings=timings or Timings())
    newton = NewtonSolver(physics, scene.solver, result.timings)
    result.linear_solver = newton.linear_solver
    result.unknowns = newton.reduction.n_global
    fraction = scene.solver.gent_limit_fraction
    try:
        if physics.gravity_factor is not None:
            _follow(GravityPreload(physics, scene), newton, result, on_converged, fraction)
        main = TimeHistory(physics, scene) if physics.dynamics is not None else LoadRamp(physics, scene)
        if physics.dynamics is not None:
            physics.dynamics.start_from(physics.state)
        _follow(main, newton, result, on_converged, fraction)
    finally:
        newton.destroy()
    return result


def _follow(path: Path, newton: NewtonSolver, result: RampResult, on_converged: Callable[..., None],
            fraction: float) -> None:
    """Adaptive stepping along a path, with cutback and retry, linear predictor and solver fallback."""
    physics = newton.physics
    eps = 1e-12 * path.end
    u_vec = compat.function_vector(physics.state)
    last = u_vec.copy()
    previous: Any = None  # state before `last`, for the linear predictor
    s, prev_step, step = 0.0, 0.0, path.initial
    retried = False  # this step already retried with the other line search
    try:
        while s < path.end - eps:
            target = next(t for t in path.targets if t > s + eps)
            trial = min(s + step, target)
            if target - trial < path.min_step:
                trial = target
            if previous is not None and prev_step > 0:  # linear predictor from the last two states
                u_vec.axpy((trial - s) / prev_step, last - previous)
                u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
                physics.sync()
                if not newton.guard.admissible():
                    last.copy(u_vec)
                    physics.sync()
            path.apply(s, trial)
            ok, its, reason = newton.solve()
            result.newton_iterations += its
            result.domain_rejections += newton.outside_domain
            if newton.floor > newton.options.atol:
                if result.floor_above_atol == 0:
                    log.info("the residual's round-off floor %.2e N is above solver.atol %.2e N: Newton stops at the "
                             "floor (recorded as residual_floor_n)", newton.floor, newton.options.atol)
                result.floor_above_atol += 1
            result.residual_floor_n = max(result.residual_floor_n, newton.floor)
            if ok and fraction < 1.0:
                limit = newton.guard.limit_reached(fraction)
                if limit is not None:
                    ok, reason = False, "physical_limit"
                    newton.last_violation = limit
            if ok:
                if previous is None:
                    previous = last.copy()
                else:
                    last.copy(previous)
                u_vec.copy(last)
                prev_step = trial - s
                s_old, s = s, trial
                hit = any(abs(s - t) <= eps for t in path.targets)
                if path.reports:
                    result.steps.append(StepRecord(path.force(s), its, prev_step, path.time(s)))
                log.info("step %3d  %s  Newton its %2d  |R| %.2e  cutbacks %d", len(result.steps), path.describe(s),
                         its, newton.residual_norm(), result.cutbacks)
                if path.reports:
                    path.before_report(s)
                    t = path.time(s)
                    on_converged(path.force(s), hit) if t is None else on_converged(path.force(s), hit, time_s=t)
                path.accept(s_old, s)
                if its <= newton.options.easy_iterations:
                    step = min(step * path.grow, path.max_step)
                retried = False
                continue
            last.copy(u_vec)
            u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            physics.sync()
            if newton.linear_failure() or reason == "petsc_error":
                fallback = newton.next_linear_solver()
                if fallback is not None:
                    result.fallbacks.append(fallback)
                    result.linear_solver = fallback
                    continue
            if reason != "physical_limit" and not retried:
                retried = True
                result.line_search_switches += 1
                log.info("Newton failed at %s (%s); retrying with the %s line search", path.describe(trial),
                         reason, newton.other_line_search())
                continue
            retried = False
            result.cutbacks += 1
            step = 0.5 * (trial - s)
            why = _diagnose(newton, reason, its)
            log.warning("step to %s failed (%s); cutting the step to %.3g", path.describe(trial), why, step)
            if step < path.min_step:
                raise SolveStopped.with_history(
                    result,
                    cause=_cause(newton, reason),
                    load_reached=path.force(s),
                    attempted=path.force(trial),
                    detail=f"{path.label} step fell below its minimum {path.min_step:g} after {result.cutbacks} "
                    f"cutbacks; last failure: {why}",
                )
    finally:
        last.copy(u_vec)  # never leave a diverged state behind, nor the loads of a failed trial
        u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        physics.sync()
        path.restore(s)
        for vec in (last, previous):
            if vec is not None:
                vec.destroy()


def _cause(newton: NewtonSolver, reason: str) -> str:
    if newton.last_violation is not None:
        v = newton.last_violation
        return "gent_limit" if v["quantity"] == GENT_LIMIT else "inverted_element"
    if newton.linear_failure():
        return "linear_solver"
    return "newton_divergence"


def _diagnose(newton: NewtonSolver, reason: str, its: int) -> str:
    v = newton.last_violation
    if reason == "physical_limit" and v is not None:
        return (f"converged in {its} iterations, but the Gent limit is reached in the {v['region']} at "
                f"r = {v['r_mm']:.3f} mm, z = {v['z_mm']:.3f} mm: {v['limit']}")
    text = f"SNES {reason} after {its} iterations"
    if v is not None:
        what = "J <= 0" if v["quantity"] == "J" else "Gent limit I1bar - 3 >= Jm"
        text += (
            f"; trial states left the admissible domain {newton.outside_domain} times ({what} in the "
            f"{v['region']} at r = {v['r_mm']:.3f} mm, z = {v['z_mm']:.3f} mm, value {v['value']:.3g})"
        )
    if newton.linear_failure():
        text += f"; linear solver {newton.linear_solver} failed"
    return text
