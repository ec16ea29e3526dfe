"""Adaptive stepping along the scene's load path (:mod:`suture_fem.solve.paths`), one Newton solve per step.

* Adaptive load stepping. A step grows (by ``solver.grow``, up to ``solver.max_step``) when Newton converges in at most
  ``solver.easy_iterations`` iterations (each solve, where the cones' multipliers are updated: ``NewtonSolver.effort``),
  and is halved and retried from the last converged state when it fails; below ``solver.min_step`` the run stops
  with a :class:`~suture_fem.support.errors.SolveStopped` diagnosis naming the cause (:mod:`~.diagnosis`).
* Milestones. Report points (and the end) are milestones the steps land on exactly; a step that would stop short of one
  by less than :data:`MILESTONE_STRETCH` of a step goes straight to it (no 2.9 -> 3.0 N stub steps), never beyond
  ``solver.max_step``.
* Futile stop. :data:`FUTILE_CUTBACKS` cutbacks in a row at the same load (the step 2^k times shorter and still failing)
  stop the path there with the diagnosis, instead of halving on to ``solver.min_step`` at hundreds of Newton
  iterations; the diagnosis says what to change (:func:`advice`).
* Leap (contact only). Where a contact state ends at a load (pressed tissue released), the next equilibrium lies further
  on and shorter steps never reach it: before stopping, the path tries one step to the next milestone (report point or
  end) from there; :data:`LEAPS` at most, counted in results.json.
* Predictor. Each trial starts from an extrapolation of the converged path: on a path whose loads are linear in s (the
  pull, the weight) from the quadratic through the last two converged states with the tangent du/ds at the last one
  (:meth:`~suture_fem.solve.newton.NewtonSolver.tangent`: one back-substitution with the factorisation Newton just
  used), or from the tangent alone, or (time histories) from the line through the last two states, or from the last
  converged state: whichever is closest to balance under the trial's loads
  (:meth:`~suture_fem.solve.newton.NewtonSolver.merit`: the potential where the line search uses it, else the residual
  norm; inadmissible states never win). Measured on the paper scene at P1, 0-4 N, Newton iterations per ramp (failed
  attempts included): the line through two states 45 (37 once :mod:`~suture_fem.solve.stopping` finished round-off
  stalls with full steps), the quadratic with the tangent, first admissible, 41 (it overshoots early in the ramp),
  chosen by merit 33, with the energy line search's hand-over 30; P2 63 -> 50 (benchmarks/newton_counts.py).
  Where every start is inadmissible (an end moved by a long step inverts the elements beside it) the step is cut
  without a Newton solve: from there SNES saw the guard's placeholder residual and stepped 3.5e6 m (P2 Coulomb thread
  under displacement control), MUMPS failed on that Jacobian, and the run went on with LU, without the inertia
  correction, for good.
* Physical limit. A converged state is checked against ``solver.gent_limit_fraction``
  (:meth:`~suture_fem.solve.guard.DomainGuard.limit_reached`) and rejected like a failed step there.
* Warm starts. A caller that has solved the same scene at nearby parameters (a calibration's previous evaluation) may
  hand :func:`ramp` a start state per report force (``warm``); the step then goes straight to that force and the start
  competes with the predictions above by merit. A Newton failure from it costs that attempt only: the path goes on
  with its usual steps, no cutback counted.
* Fallbacks before a cutback. A failed solve first switches the linear solver, if the factorisation failed, then retries
  once with the other line search (:mod:`suture_fem.solve.newton`); only then is the step cut.
* A path-following start (``loading.start_force_n``): :mod:`suture_fem.solve.start`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import Any

from petsc4py import PETSc

from suture_fem.physics.effects.friction import slip_laws
from suture_fem.physics.problem import Physics
from suture_fem.scene.balance import BALANCE_TOL
from suture_fem.scene.model import Scene
from suture_fem.solve.diagnosis import INADMISSIBLE_START, PHYSICAL_LIMIT, advice, failure_text, stop_cause
from suture_fem.solve.newton import PETSC_ERROR, NewtonSolver
from suture_fem.solve.paths import DisplacementRamp, GravityPreload, LoadRamp, Path, TimeHistory
from suture_fem.solve.records import RampResult, StepRecord, Timings
from suture_fem.solve.start import displacement_start, switch_to_force
from suture_fem.solve.stopping import force_scale
from suture_fem.support import compat
from suture_fem.support.errors import SolveStopped

log = logging.getLogger("suture_fem")

#: Cutbacks in a row at one load after which the path stops (the step is then 64x shorter than the
#: one that first failed there; a step that shrinks this much without converging does not recover).
FUTILE_CUTBACKS = 6
#: Cutbacks in a ramp after which a scene with unilateral contact stops: where the tissue opens off the thread
#: next to a tied corner, steps can succeed at ever smaller increments between failures (P2, 0.885 ->
#: 0.887 N in 5 minutes on the paper scene) and never trip FUTILE_CUTBACKS; this bounds that cost.
CONTACT_CUTBACKS = 12
#: Long steps a ramp with contact may try where it would stop (see the module docstring).
LEAPS = 3
#: The reason of a solve that met SNES's tests but left the state short of the force balance.
UNBALANCED = "UNBALANCED"
#: A step is stretched to the next milestone when less than this fraction of a step would remain.
MILESTONE_STRETCH = 0.5


def ramp(
    physics: Physics,
    scene: Scene,
    on_converged: Callable[..., None],
    timings: Timings | None = None,
    with_solver: bool = False,
    warm: Callable[[float], Any] | None = None,
    solver: NewtonSolver | None = None,
) -> RampResult:
    """Follow the scene's load path: gravity preload (if called), then the load ramp or the time history.

    ``on_converged(force_n, is_report_point)`` is called after every converged step of the pull
    (with inertia also ``time_s=t``; with ``with_solver`` also ``solver=`` the NewtonSolver, whose
    :meth:`~suture_fem.solve.newton.NewtonSolver.solve_reduced` reuses the step's factorisation); report
    points (``loading.report_forces_n``, the peak and, with inertia, the end of the hold) are always hit
    exactly. ``warm(force_n)``: a start state for a report force of the quasi-static pull (the state's
    local array, ghosts included) or None (module docstring). ``solver``: a NewtonSolver of this physics
    and ``scene.solver`` kept by the caller (a Model), restarted here and left alive; without it one is
    built and freed. Raises SolveStopped (with every converged step already handed to on_converged) when
    it cannot go on.
    """
    result = RampResult(timings=timings or Timings())
    newton = (solver.restart(result.timings) if solver is not None
              else NewtonSolver.of(physics, scene.solver, result.timings))
    result.linear_solver, result.unknowns = newton.linear_solver, newton.reduction.n_global
    result.trust_region = newton.trust.begin() if newton.trust is not None else None
    fraction = scene.solver.gent_limit_fraction
    try:
        if physics.gravity_factor is not None:
            _Stepper(GravityPreload(physics, scene), newton, result, on_converged, fraction, with_solver).run()
        main = (TimeHistory(physics, scene) if physics.dynamics is not None
                else DisplacementRamp(physics, scene) if physics.control is not None else LoadRamp(physics, scene))
        if physics.dynamics is not None:
            physics.dynamics.start_from(physics.state)
        start = physics.control is None and isinstance(main, LoadRamp) and scene.loading.start_force_n > 0
        reached = displacement_start(physics, scene, result, _Stepper, on_converged, fraction) if start else 0.0
        stepper = _Stepper(main, newton, result, on_converged, fraction, with_solver)
        if start:  # on from the start's state, under force control (solve/start.py)
            switch_to_force(stepper, main, reached)
        stepper.warm = warm if isinstance(main, LoadRamp) else None
        stepper.run()
    finally:
        if solver is None:
            newton.destroy()
    return result


class _Stepper:
    """Adaptive stepping along one path, with cutback and retry, linear predictor and solver fallback."""

    def __init__(self, path: Path, newton: NewtonSolver, result: RampResult, on_converged: Callable[..., None],
                 fraction: float, with_solver: bool = False):
        self.path, self.newton, self.result, self.on_converged, self.fraction = (
            path, newton, result, on_converged, fraction)
        self.physics = newton.physics
        self.extra = {"solver": newton} if with_solver else {}  # for on_converged
        self.eps = 1e-12 * path.end
        self.u_vec = compat.function_vector(self.physics.state)
        self.last = self.u_vec.copy()  # the last converged state
        self.kept = [(law, law.frozen()) for law in slip_laws(self.physics)]  # its laws' bounds and multipliers
        self.previous: Any = None  # state before `last`, for the predictor
        self.tangent: Any = None  # du/ds at `last`, when the path's loads are linear in s and it was had
        self.rate: Any = None  # -dR/ds on the unknowns, for the tangent
        self.s, self.prev_step, self.step = 0.0, 0.0, path.initial
        self.retried, self.cuts_here = False, 0  # this step retried with the other line search; cutbacks in a row at s
        self.leapt_from: float | None = None  # the load the last leap started from
        self.warm: Callable[[float], Any] | None = None  # start states at report forces (ramp's ``warm``)
        self.warm_tried: set[float] = set()  # targets whose warm start was tried
        self.warm_attempt = False  # the solve under way started from a warm start
        self._warm_built: tuple[float | None, Any] = (None, None)  # (s, the caller's state there)

    def run(self) -> None:
        """Step from s = 0 to the path's end (raises SolveStopped when the step falls below its minimum)."""
        try:
            if not self.path.dead_load:  # a prescribed displacement: start along the tangent from rest too
                self._update_tangent()
            while self.s < self.path.end - self.eps:
                trial = self._next_trial()
                self.path.apply(self.s, trial)
                if self._predict(trial):
                    ok, its, reason = self._solve()
                else:  # no admissible start: no Newton solve (module docstring)
                    ok, its, reason = False, 0, INADMISSIBLE_START
                if ok:
                    self._accept(trial, its)
                else:
                    self._reject(trial, its, reason)
        finally:
            self._set_state(self.last)  # never leave a diverged state behind, nor the loads of a failed trial
            self.path.restore(self.s)
            for law, kept in self.kept:  # nor the contact's multipliers and bounds of a failed trial
                law.thaw(kept)
            for vec in (self.last, self.previous, self.tangent, self.rate):
                if vec is not None:
                    vec.destroy()

    def _set_state(self, vec: Any) -> None:
        vec.copy(self.u_vec)
        self.u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.physics.sync()

    def _next_trial(self) -> float:
        """S + step, clipped to the next milestone, and stretched to it when only a stub would remain."""
        path = self.path
        target = next(t for t in path.targets if t > self.s + self.eps)
        if self._warm_state(target) is not None:
            return target
        trial = min(self.s + self.step, target)
        stub = max(path.min_step, MILESTONE_STRETCH * self.step)
        return target if target - trial < stub and target - self.s <= path.max_step + self.eps else trial

    def _predict(self, trial: float) -> bool:
        """Start the trial from the extrapolation of the path closest to balance (module docstring).

        False when every start is outside the admissible domain (the newton's last violation is then the start's).
        """
        h, hp = trial - self.s, self.prev_step
        has_previous = self.previous is not None and hp > 0
        candidates = []
        if self.tangent is not None:
            if has_previous:  # u_k + h t_k + c h^2 through u_{k-1}: c = (u_{k-1} - u_k + hp t_k) / hp^2
                curve = self.previous - self.last
                curve.axpy(hp, self.tangent)
                candidates.append([(h, self.tangent), (h * h / (hp * hp), curve)])
            candidates.append([(h, self.tangent)])
        elif has_previous:
            candidates.append([(h / hp, self.last - self.previous)])
        warm, warm_terms = self._warm_state(trial), None
        if warm is not None:
            self.warm_tried.add(trial)
            start = self.u_vec.duplicate()
            with start.localForm() as local:
                local.array[:] = warm
            start.axpy(-1.0, self.last)
            warm_terms = [(1.0, start)]
            candidates.append(warm_terms)
        self._combine([])  # the last state under the trial's loads (a prescribed end moved to the trial's place)
        self.newton.guard.anchor()  # every start is a way from it
        best, best_merit = [], self.newton.merit() if candidates else 0.0
        for terms in candidates:
            self._combine(terms)
            merit = self.newton.merit()
            if merit < best_merit:
                best, best_merit = terms, merit
        self._combine(best)
        self.warm_attempt = best is warm_terms and warm_terms is not None  # a failure then costs this attempt only
        for terms in candidates:
            for _, vec in terms:
                if vec is not self.tangent:
                    vec.destroy()
        if best_merit < float("inf") or self.newton.guard.admissible():
            return True
        self.newton.outside_domain, self.newton.last_violation = 1, self.newton.guard.violation
        return False

    def _warm_state(self, s: float) -> Any:
        """The caller's start state for the load s (a report force not yet tried from it), else None.

        Asked by :meth:`_next_trial` and again by :meth:`_predict` for the same s: the caller's state is
        built once per s.
        """
        if self.warm is None or s in self.warm_tried or not any(abs(s - t) <= self.eps for t in self.path.targets):
            return None
        if self._warm_built[0] != s:
            self._warm_built = (s, self.warm(self.path.force(s)))
        return self._warm_built[1]

    def _combine(self, terms: list[tuple[float, Any]]) -> None:
        """Set the state to the last converged one plus the given multiples of vectors."""
        self.last.copy(self.u_vec)
        for factor, vec in terms:
            self.u_vec.axpy(factor, vec)
        self.u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.physics.sync()
        reduction = self.newton.reduction
        if reduction.offset is not None:  # a prescribed end: every candidate with the end where the trial puts it
            reduction.restrict(self.u_vec, self.newton.x)
            reduction.expand(self.newton.x)

    def _solve(self) -> tuple[bool, int, str]:
        """One Newton solve, counted; a converged state past the Gent limit fraction counts as failed."""
        newton, result = self.newton, self.result
        ok, its, reason = newton.solve()
        result.newton_iterations += its
        result.domain_rejections += newton.outside_domain
        result.inertia_shifts += newton.inertia_shifts
        if newton.floor > newton.options.atol:
            if result.floor_above_atol == 0:
                log.info("the residual's round-off floor %.2e N is above solver.atol %.2e N: Newton stops at the "
                         "floor (recorded as residual_floor_n)", newton.floor, newton.options.atol)
            result.floor_above_atol += 1
        result.residual_floor_n = max(result.residual_floor_n, newton.floor)
        # converged means balanced (scene/balance.py): to BALANCE_TOL of the force, or to the residual's
        # round-off floor where that is higher (a moved end that takes almost no force)
        force = force_scale(self.physics) if ok else 0.0  # (collective: under displacement control an assembly)
        if ok and newton.residual_norm() > max(BALANCE_TOL * force, newton.floor):
            log.info("Newton stopped (%s) at |R| %.2e N, above %g of the force %.3g N: not balanced", reason,
                     newton.residual_norm(), BALANCE_TOL, force)
            ok, reason = False, UNBALANCED
        if ok and self.fraction < 1.0:
            limit = newton.guard.limit_reached(self.fraction)
            if limit is not None:
                ok, reason = False, PHYSICAL_LIMIT
                newton.last_violation = limit
        return ok, its, reason

    def _accept(self, trial: float, its: int) -> None:
        """Keep the converged state, report it, and grow the step after an easy solve."""
        path, result = self.path, self.result
        if self.previous is None:
            self.previous = self.last.copy()
        else:
            self.last.copy(self.previous)
        self.u_vec.copy(self.last)
        self.kept = [(law, law.frozen()) for law, _ in self.kept]
        self.prev_step = trial - self.s
        s_old, self.s = self.s, trial
        s = self.s
        hit = any(abs(s - t) <= self.eps for t in path.targets)
        if path.reports:
            result.steps.append(StepRecord(path.force(s), its, self.prev_step, path.time(s)))
        log.info("step %3d  %s  Newton its %2d  |R| %.2e  cutbacks %d", len(result.steps), path.describe(s),
                 its, self.newton.residual_norm(), result.cutbacks)
        if path.reports:
            path.before_report(s)
            t = path.time(s)
            if t is None:
                self.on_converged(path.force(s), hit, **self.extra)
            else:
                self.on_converged(path.force(s), hit, time_s=t, **self.extra)
        path.accept(s_old, s)
        self._update_tangent()
        if self.newton.effort <= self.newton.options.easy_iterations:
            self.step = min(self.step * path.grow, path.max_step)
        self.retried = False
        self.cuts_here = 0

    def _update_tangent(self) -> None:
        """Du/ds at the state just accepted, where the path's loads are linear in s (else none)."""
        if not self.path.linear_in_s:
            return
        if self.tangent is None:
            self.tangent = self.u_vec.duplicate()
        if self.rate is None or not self.path.dead_load:  # -dR/ds: dead loads, the same all along the path
            if self.rate is not None:
                self.rate.destroy()
            self.rate = self.newton.load_rate(lambda v: self.path.apply(v, v), self.s, self.path.rate_step)
        if not self.newton.tangent(self.rate, self.tangent):
            self.tangent.destroy()
            self.tangent = None

    def _reject(self, trial: float, its: int, reason: str) -> None:
        """Back to the last converged state; then the next linear solver, the other line search, or a cutback."""
        self._set_state(self.last)
        newton, result = self.newton, self.result
        if self.warm_attempt:  # the warm start did not converge: the usual steps from the last state
            self.warm_attempt = False
            log.info("Newton failed from the warm start at %s (%s); stepping there as usual",
                     self.path.describe(trial), reason)
            return
        if reason == INADMISSIBLE_START:  # no solve was made: nothing to retry at this step
            return self._cut(trial, its, reason)
        if newton.linear_failure() or reason == PETSC_ERROR:
            fallback = newton.next_linear_solver()
            if fallback is not None:
                result.fallbacks.append(fallback)
                result.linear_solver = fallback
                return
        if reason != PHYSICAL_LIMIT and not self.retried:
            self.retried = True
            result.line_search_switches += 1
            log.info("Newton failed at %s (%s); retrying with the %s line search", self.path.describe(trial),
                     reason, newton.other_line_search())
            return
        self._cut(trial, its, reason)

    def _cut(self, trial: float, its: int, reason: str) -> None:
        """Halve the step; below the path's minimum, stop with the diagnosis."""
        path, result = self.path, self.result
        self.retried = False
        result.cutbacks += 1
        self.cuts_here += 1
        self.step = 0.5 * (trial - self.s)
        why = failure_text(self.newton, reason, its)
        log.warning("step to %s failed (%s); cutting the step to %.3g", path.describe(trial), why, self.step)
        futile = self.cuts_here >= FUTILE_CUTBACKS
        effects = getattr(self.physics, "effects", None)
        crawl = effects is not None and effects.contact and result.cutbacks >= contact_cutbacks(effects)
        if (self.step < path.min_step or futile or crawl) and self._leap(trial, effects):
            return
        if self.step < path.min_step or futile or crawl:
            cause = stop_cause(self.newton)
            stop = (f"{self.cuts_here} cutbacks in a row at this load (the step {2 ** self.cuts_here}x shorter, still "
                    "failing)" if futile else f"{path.label} step fell below its minimum {path.min_step:g}")
            stop = f"{contact_cutbacks(effects)} cutbacks in this ramp with contact" if crawl and not futile else stop
            tip = advice(self.physics, cause, self.newton.last_violation)
            raise SolveStopped.with_history(
                result,
                cause=cause,
                load_reached=path.force(self.s),
                attempted=path.force(trial),
                detail=f"{stop} after {result.cutbacks} cutbacks; last failure: {why}{tip}",
            )

    def _leap(self, trial: float, effects: Any) -> bool:
        """Instead of stopping, one long step from the last converged state, where contact allows it."""
        result, path = self.result, self.path
        if effects is None or not effects.contact or result.leaps >= LEAPS or self.leapt_from == self.s:
            return False
        result.leaps, self.leapt_from, self.cuts_here = result.leaps + 1, self.s, 0
        self.step = min([t for t in (*path.targets, path.end) if t > self.s + self.eps]) - self.s  # the next milestone
        log.warning("the path would stop at %s; one long step (%.3g) from there", path.describe(self.s), self.step)
        return True


def contact_cutbacks(effects: Any) -> int:
    """Cutbacks a ramp with contact may take before it stops as a crawl: twice as many with the cones' contact.

    Four frictionless cones reach 4 N after 16 cutbacks (docs/contact.md); a unilateral thread that has
    needed 12 creeps on (docs/hardcases.md).
    """
    return CONTACT_CUTBACKS if effects.unilateral_thread else 2 * CONTACT_CUTBACKS
