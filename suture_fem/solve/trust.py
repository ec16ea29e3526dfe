"""A trust region on the energy: the Newton solve's fallback where its line search fails (P2 unilateral cones).

SNES's Newton step (:mod:`suture_fem.solve.newton`) goes along one direction per iteration: the step of the
inertia-corrected Jacobian, shortened by the backtracking line search until the energy falls. Where the P2
cones' tissue is pressed round a corner, that direction is dominated by a few soft modes; its trial states
invert a tissue element, the line search shortens the same direction, and the solve fails however short the
load step (docs/contact.md, "P2 cones"). A trust region turns the direction as it shortens the step, toward
the energy's steepest descent.

The Levenberg-Marquardt form (Moré 1978; Nocedal & Wright, Numerical Optimization, 2nd ed., section 4.3):
the step p(lam) = -(A + lam D)^-1 g, A the exact Jacobian (the cones' softening beside a convex arc
included: :func:`~suture_fem.solve.jacobian.exact`), D = |diag A|, g the residual, lam at least lam0, the
smallest of 0, 1e-8, 1e-7, ... whose factorisation (MUMPS LDL^T) has no negative pivot, and large enough
that |p| <= delta (lam found by interpolating log |p| against log lam: |p(lam)| falls as lam grows). Where 0
has one, lam0 is sought from one rung below the last shifted Jacobian's, up, and not down from there: on the
P2 cones the search down cost 4.5 factorisations per shifted Jacobian. A step is kept when the energy falls
by at least RHO_KEEP of what the quadratic model g.p + p.A p / 2 predicts (a trial state outside the admissible
domain counts as a rise); delta then grows to GROW x |p| after a well-predicted step that the radius held. A
refused one is tried at half and a quarter of its length (an energy evaluation each, no factorisation; on
the P2 cones most refusals are an element beside a rim inverted by a step of the grown radius), and where
neither is kept delta shrinks to SHRINK x |p|. Below the
energy's rounding (|g| < FULL_STEP_RESIDUAL x force, or a predicted fall below 1e-11 of the energy) a step
is kept where it lowers |g|, and a refused one takes the residual's round-off floor at the iterate (the
Newton solve's is taken at the solve's start, 0 at rest: a first step from rest failed at |g| 1.15e-10 N
against an atol of 1e-10 N); the next solve starts from the radius before those refusals (it had started
from 1e-14 m and spent 12 iterations growing it). The solve ends at the Newton solve's own residual test.
Where lam0 > 0 and |p| lies inside the radius, lam0's tenfold rung has overshifted the step (a third of the
P2 cones' iterations crawled so, a few um each): it is completed along the negative curvature
(:mod:`~suture_fem.solve.curvature`), and where that completion is refused the step as it was is tried
next. Where the cones are
unilateral (2-D) the model also keeps each open pair's penalty on its linearised gap, and a step that presses
open pairs is solved again with them joined (:mod:`~suture_fem.physics.effects.cone_model`): without them the
trust region refused every step that pressed a node lying 0.3 um off its cone and crawled toward it.

Used only where SNES's solve failed, from that solve's start (``solver.trust_region``): "auto" for the
unilateral (frictionless or Coulomb) cones: at P2, whose ramps stopped near 1 N without it; in 3-D, where they
stopped at 0.21 of 0.5 N; at P1, where it took the paper scene's cutbacks away (docs/contact.md,
"The trust region for the P1 cones"), but not with the thread free too (nothing tied: not finished within 900 s
where Newton alone stops at 4.9 of 8 mm in 416 s); "on" for every solve with the energy objective and LDL^T
(on the sliding cones and the P1 threads it cost more than it saved), "off" never. A scene it does not touch is
solved bit for bit as without it.

Hand-written: PETSc 3.18's SNESNEWTONTR is the MINPACK trust region on the residual's norm, not on an
objective, and bounds its step by ending a Krylov solve early (a direct factorisation is not bounded);
TAO's trust-region Newton (NTR) needs a Krylov trust-region solver (STCG, NASH, GLTR) with a positive
definite preconditioner, which the shifted factorisation here is not wired into.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from mpi4py import MPI

from suture_fem.physics.effects.cone_model import GapModel
from suture_fem.solve import curvature, inertia, jacobian
from suture_fem.solve.stopping import FULL_STEP_RESIDUAL, force_scale
from suture_fem.solve.trust_work import NoShift, Work, falls, kept, shifted_solve
from suture_fem.support import compat

log = logging.getLogger("suture_fem")

#: A kept step whose fall was at least RHO_GOOD of the prediction, and that the radius held, grows it to GROW |p|.
RHO_GOOD, GROW = 0.75, 4.0
#: A rejected step shrinks the radius to SHRINK |p|; below MIN_RADIUS (in the unknowns' 2-norm, m) the solve fails.
SHRINK, MIN_RADIUS = 0.25, 1e-14
#: The first radius of a run (m); later solves start from the last one's.
FIRST_RADIUS = 1e-3
#: Shifts of lam0's ladder (times |diag A|) after 0; beyond the last the Jacobian counts as failed.
FIRST_SHIFT, LAST_SHIFT = 1e-8, 1e6
SHIFTS = [FIRST_SHIFT * 10.0**k for k in range(15)]  # 1e-8 ... 1e6
#: The rung a ramp's first shifted Jacobian is tried at (1e-3), and searched down from where it has no negative pivot.
FIRST_RUNG = 5
#: A refused step is tried again at these fractions of its length (objective evaluations, no factorisation).
SHORTER = (0.5, 0.25)
#: Tries at the shift that puts |p| between half the radius and the radius.
SHIFT_TRIES = 6
#: Iterations of one solve, in units of ``solver.max_iterations``.
ITERATIONS_PER_MAX = 8
#: Solves of one step's model with the pairs it presses joined (:mod:`~suture_fem.physics.effects.cone_model`).
JOINS = 4


class TrustRegion:
    """The trust-region solve of a :class:`~suture_fem.solve.newton.NewtonSolver` (its state, forms and KSP).

    ``record``: the current ramp's counts (:meth:`begin`): solves, converged, iterations, factorisations.
    """

    def __init__(self, newton: Any):
        """The fallback of ``newton``; :meth:`of` says whether a scene wants one."""
        self.newton = newton
        self.delta = FIRST_RADIUS
        self.rung: int | None = None  # the last shifted Jacobian's lam0 on SHIFTS (the ramp's; None: none yet)
        self.gaps = GapModel.of(newton.physics, newton.reduction)  # the open pairs in the model, or None
        self.record: dict[str, int] = self.begin()

    @classmethod
    def of(cls, newton: Any) -> TrustRegion | None:
        """The fallback ``solver.trust_region`` asks for, or None (off, or no energy objective or LDL^T)."""
        mode = newton.options.trust_region
        contact = getattr(newton.physics, "cone_contact", None)
        free_thread = bool(getattr(getattr(newton.physics, "effects", None), "thread_track", False))  # nothing tied
        cones = contact is not None and not contact.bilateral and (contact.safeguarded or not free_thread)
        wanted = mode == "on" or (mode == "auto" and cones)
        usable = newton.objective_form is not None and newton.options.inertia_correction
        return cls(newton) if wanted and usable else None

    def begin(self) -> dict[str, int]:
        """A new ramp's counts (the ramp's record holds the same dict), the first radius again."""
        self.delta, self.rung = FIRST_RADIUS, None
        self.record = {"solves": 0, "converged": 0, "iterations": 0, "factorisations": 0}
        return self.record

    def after(self, solve_once: Callable[..., tuple[bool, int, str]]) -> Callable[..., tuple[bool, int, str]]:
        """``solve_once``, and where it fails (LDL^T by MUMPS) the trust region from the same start."""
        def solve(loose: float = 0.0) -> tuple[bool, int, str]:
            state = self.newton.physics.state
            start = state.x.array.copy()
            ok, its, reason = solve_once(loose)
            pc = self.newton.snes.getKSP().getPC()
            if ok or pc.getType() != "cholesky" or self.newton.linear_solver != "mumps":
                return ok, its, reason
            state.x.array[:] = start
            state.x.scatter_forward()
            ok, more, why = self.solve(loose)
            log.info("trust region after %s (%d iterations): %s in %d iterations", reason, its, why, more)
            return ok, its + more, why if ok else reason
        return solve

    def solve(self, loose: float = 0.0) -> tuple[bool, int, str]:
        """One solve from the current state; returns (converged, iterations, reason) as a Newton solve does."""
        newton = self.newton
        self.record["solves"] += 1
        t0, a0 = time.perf_counter(), newton.timings.assembly + newton.timings.guard
        newton.stops.loose = loose
        newton.reduction.restrict(compat.function_vector(newton.physics.state), newton.x)
        newton.last_violation = None
        work = Work(newton.x)
        try:
            with newton.memo.open():
                ok, its, reason = self._iterate(work, loose)
            self.delta = max(self.delta, work.carry)  # the next solve: the radius before the rounding's refusals
        finally:
            work.destroy()
            newton.snes.getKSP().setOperators(newton.A, newton.A)
            newton.jacobian_current = newton.factorised = False  # the KSP's factorisation was a shifted copy's
            spent = time.perf_counter() - t0
            newton.timings.newton_total += spent
            newton.timings.linear_solve += spent - (newton.timings.assembly + newton.timings.guard - a0)
        newton.largest_solve = max(newton.largest_solve, its)
        newton.reduction.expand(newton.x)
        finite = bool(np.all(np.isfinite(newton.physics.state.x.array)))
        ok = ok and bool(newton.physics.comm.allreduce(finite, op=MPI.LAND))
        self.record["iterations"] += its
        self.record["converged"] += int(ok)
        return ok, its, reason

    def _iterate(self, w: Work, loose: float) -> tuple[bool, int, str]:
        """The iterations from ``newton.x`` (collective); x is left at the last kept iterate."""
        newton = self.newton
        x, g = newton.x, newton.b
        f = newton._objective(None, x)
        if not newton.memo.admissible:  # a start outside the domain (a predictor's): nothing to descend from
            return False, 0, "DIVERGED_FUNCTION_DOMAIN"
        newton._residual(None, x, g)
        self._jacobian()
        self._centre(x)
        newton.floor = newton.round_off_floor(x)
        atol, force = max(newton.absolute_tolerance(), loose), force_scale(newton.physics)
        its, fresh = 0, True
        while its < ITERATIONS_PER_MAX * newton.options.max_iterations:
            gnorm = g.norm()
            if gnorm <= atol:
                return True, its, "CONVERGED_FNORM_ABS"
            if fresh:  # a new Jacobian: its shift without negative pivots and the step there
                w.matrix(newton.A)
                try:
                    w.lam0 = self._lowest_shift(w)
                except NoShift:
                    return False, its, "DIVERGED_LINEAR_SOLVE"
                w.norm0 = shifted_solve(newton.snes.getKSP(), g, w.p0)
                fresh = False
            norm = self._step(w, g)
            newton.A.mult(w.p, w.Ap)
            predicted = -(g.dot(w.p) + 0.5 * w.p.dot(w.Ap)) - w.pressing
            w.trial.waxpy(1.0, w.p, x)
            ft = newton._objective(None, w.trial)
            its += 1
            rounding = gnorm < FULL_STEP_RESIDUAL * force or abs(predicted) < 1e-11 * abs(f)
            keep = kept(newton, w, f, ft, predicted, rounding, gnorm)
            log.debug("trust region %d: |g| %.3e, lam0 %.1e, |p| %.3e (radius %.2e, %d joins, curvature %.1e), "
                      "energy %+.3e of %+.3e predicted%s", its, gnorm, w.lam0, norm, self.delta, w.joins, w.theta,
                      f - ft, predicted, "" if keep else ", refused")
            if not rounding:
                w.carry = self.delta
                if not keep:  # along the refused step, shorter (no factorisation)
                    keep, ft, norm, predicted = self._shorter(w, x, g, f, norm)
            if keep:
                f, fresh = self._accept(w, x, g, f, ft, predicted, norm), True
            else:  # refused; where the step had been completed along z (norm > base), next the step before that
                self.delta = max(SHRINK * norm, w.base) if norm > w.base else SHRINK * norm
                newton.reduction.expand(x)
                if rounding:  # refused at the energy's rounding: the residual's own floor here, not at the start
                    newton.floor = max(newton.floor, newton.round_off_floor(x))
                    atol = max(newton.absolute_tolerance(), loose)
                    if gnorm <= atol:
                        return True, its, "CONVERGED_FNORM_ABS"
                if self.delta < MIN_RADIUS:
                    return False, its, "DIVERGED_TR_DELTA"
        return False, its, "DIVERGED_MAX_IT"

    def _accept(self, w: Work, x: Any, g: Any, f: float, ft: float, predicted: float, norm: float) -> float:
        """Move x to the trial state (its residual into g, its Jacobian); returns its energy ``ft``.

        The radius grows after a well-predicted step that it held.
        """
        ratio = (f - ft) / predicted if predicted > 0 else 1.0
        w.trial.copy(x)
        self.newton._residual(None, x, g)
        self._jacobian()
        self._centre(x)
        if ratio > RHO_GOOD and norm > 0.45 * self.delta:
            self.delta = max(self.delta, GROW * norm)
        return ft

    def _shorter(self, w: Work, x: Any, g: Any, f: float, norm: float) -> tuple[bool, float, float, float]:
        """The refused step p tried at the fractions :data:`SHORTER` of its length, each against its own prediction.

        Backtracking inside the trust region (Nocedal and Yuan 1998): most refusals on the P2 cones are a trial
        state that inverts an element beside a rim, after the radius grew; a shorter step along p costs an
        energy evaluation where a new radius costs factorisations. Kept: p scaled, the radius its length (grown from
        there by the caller as after any step). Returns (kept, its energy, |p|, its prediction) as the caller's;
        unchanged where none is kept (the last one tried's energy and prediction).
        """
        newton = self.newton
        gp, pAp = g.dot(w.p), w.p.dot(w.Ap)  # Ap: A p, the caller's prediction's
        change = None if self.gaps is None else self.gaps.change(w.p)
        ft = predicted = 0.0
        for alpha in SHORTER:
            pressing = 0.0 if change is None else self.gaps.energy(alpha * change)
            predicted = -(alpha * gp + 0.5 * alpha * alpha * pAp) - pressing
            w.trial.waxpy(alpha, w.p, x)
            ft = newton._objective(None, w.trial)
            if newton.memo.admissible and falls(f, ft, predicted):
                w.p.scale(alpha)
                self.delta = alpha * norm
                log.debug("trust region: kept at %.2f of the step, energy %+.3e of %+.3e predicted", alpha, f - ft,
                          predicted)
                return True, ft, alpha * norm, predicted
        return False, ft, norm, predicted

    def _jacobian(self) -> None:
        """The exact Jacobian at the current state into ``newton.A`` (its trial states start here)."""
        newton = self.newton
        t0 = time.perf_counter()
        newton.guard.anchor()
        with jacobian.exact(newton.physics):
            newton._assemble_full_jacobian()
        newton.A_full.ptap(newton.reduction.T, newton.A)
        newton.timings.assembly += time.perf_counter() - t0

    def _factorise(self, w: Work, lam: float) -> bool:
        """Factorise A + lam D into the KSP; whether it has no negative pivot (a failed one counts as having)."""
        self.record["factorisations"] += 1
        return inertia.shifted_definite(self.newton.snes.getKSP(), w.M, w.diag, w.scale, lam)

    def _lowest_shift(self, w: Work) -> float:
        """lam0: the smallest of 0 and :data:`SHIFTS` whose factorisation has no negative pivot (left in the KSP).

        :func:`~suture_fem.solve.inertia.smallest_shift` on this ladder, from one below the last shifted Jacobian's
        rung (of this ramp, across solves), taken where it has no negative pivot: no search further down, whose
        factorisations cost more than the rung overshifts (the step is then completed along the negative
        curvature); a ramp's first from :data:`FIRST_RUNG`, searched both ways.
        """
        if self._factorise(w, 0.0):
            return 0.0
        known = self.rung is not None
        start = max(self.rung - 1, 0) if known else FIRST_RUNG
        self.rung, extra = inertia.smallest_shift(self.newton.snes.getKSP(), w.M, w.diag, w.scale, SHIFTS, start,
                                                  down=not known)
        self.record["factorisations"] += extra
        if self.rung is None:
            raise NoShift
        return SHIFTS[self.rung]

    def _centre(self, x: Any) -> None:
        """The open pairs' model (where kept) centred on the iterate ``x``."""
        if self.gaps is not None:  # the state is x: its residual was just assembled there
            self.gaps.at(compat.function_vector(self.newton.physics.state))

    def _step(self, w: Work, g: Any) -> float:
        """The model's step into ``w.p`` with |p| <= delta; returns |p|. ``w.pressing``: the open pairs' model energy.

        The expansion's step p(lam) (:meth:`_shifted_step`); where that presses open pairs, the step of the model
        with them joined (:meth:`_joined_step`).
        """
        w.pressing, w.joins, w.theta = 0.0, 0, 0.0
        norm = self._shifted_step(w, g)
        interior = w.norm0 <= self.delta
        if self.gaps is not None:
            lam = w.lam0 if interior else w.lam
            joined = np.zeros(self.gaps.contact.pairs, dtype=bool)
            change = self.gaps.change(w.p)
            for _ in range(JOINS):
                pressed = self.gaps.pressed(change)
                if not self.gaps.any(pressed & ~joined):
                    break
                joined |= pressed
                w.joins += 1
                norm = self._joined_step(w, g, joined, lam)
                change = self.gaps.change(w.p)
        w.base = norm
        if interior and w.lam0 > 0.0:  # overshifted: on along the negative curvature
            extra = (lambda p: 0.0) if self.gaps is None else (lambda p: self.gaps.energy(self.gaps.change(p)))
            norm, w.theta = curvature.to_boundary(self.newton.snes.getKSP(), self.newton.A, w.scale, g, w.p,
                                                  self.delta, extra)
        if self.gaps is not None:
            w.pressing = self.gaps.energy(change if norm == w.base else self.gaps.change(w.p))
        return norm

    def _joined_step(self, w: Work, g: Any, joined: np.ndarray, lam: float) -> float:
        """The step of the model with the ``joined`` open pairs' terms, shifted by ``lam`` and cut to the radius."""
        newton = self.newton
        w.joined(newton)
        self.gaps.add(joined, w.F, w.b)
        w.K = w.F.ptap(newton.reduction.T) if w.K is None else w.F.ptap(newton.reduction.T, w.K)
        newton.reduction.T.multTranspose(w.b, w.g)
        w.g.axpy(1.0, g)
        diag = w.K.getDiagonal()
        self.record["factorisations"] += 1
        try:
            inertia.shifted_definite(newton.snes.getKSP(), w.K, diag, w.scale, lam)
        finally:
            diag.destroy()
        norm = shifted_solve(newton.snes.getKSP(), w.g, w.p)
        if norm > self.delta:
            w.p.scale(self.delta / norm)
            norm = self.delta
        return norm

    def _shifted_step(self, w: Work, g: Any) -> float:
        """The step p(lam) into ``w.p`` with |p| <= delta (lam >= lam0); returns |p|."""
        if w.norm0 <= self.delta:
            w.p0.copy(w.p)
            return w.norm0
        ksp = self.newton.snes.getKSP()
        lo, norm_lo = w.lam0, w.norm0
        hi = max(w.lam, 10.0 * w.lam0, FIRST_SHIFT)
        while True:  # bracket: |p(lo)| > delta >= |p(hi)|
            self._factorise(w, hi)
            norm = shifted_solve(ksp, g, w.p)
            if norm <= self.delta:
                break
            lo, norm_lo, hi = hi, norm, 30.0 * hi
            if hi > LAST_SHIFT:
                break
        for _ in range(SHIFT_TRIES):
            if norm >= 0.5 * self.delta:
                break
            if lo > 0:  # log |p| linear in log lam between the bracket's ends, aimed at 0.75 delta
                t = (np.log(norm_lo) - np.log(0.75 * self.delta)) / (np.log(norm_lo) - np.log(norm))
                mid = float(np.exp(np.log(lo) + min(max(t, 0.1), 0.9) * (np.log(hi) - np.log(lo))))
            else:
                mid = hi / 30.0
            self._factorise(w, mid)
            trial = shifted_solve(ksp, g, w.Ap)
            if trial <= self.delta:
                hi, norm = mid, trial
                w.Ap.copy(w.p)
            else:
                lo, norm_lo = mid, trial
        w.lam = hi
        return norm
