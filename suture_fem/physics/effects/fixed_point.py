"""The fixed point of the slip bounds and multipliers updated between Newton solves (:func:`settle`).

Coulomb's slip bound (:class:`~suture_fem.physics.effects.friction.SlipBound`: the thread's and the cones')
is frozen during a Newton solve, so the Jacobian stays symmetric and the line search's energy exact, and
moved toward mu p between solves; an augmented Lagrangian's multipliers toward the pressure. Each update
of the bound shrinks the law's residual by a factor of about 0.04-0.07 on the paper scene (mu 0.1), so a
step needs five or six updates from the first solve's 1e-4 N to the solver's 1e-10 N. Those updates are
cheap where the state follows them by chord steps (the last factorisation, one residual, one
back-substitution: the bound's change barely moves the Jacobian) instead of Newton solves of their own,
and the first solve need not be exact either (it stops at :data:`FORCING` of the law's residual); a last
full Newton solve, after which every law holds, gives the answer, as before (docs/contact.md, "A cheaper
Coulomb"). Where no Coulomb bound is updated (frictionless cones, the thread tied or sliding), the cones'
multipliers take the same chord steps (their Jacobian depends on them only through the rims' curvature term)
after a first full solve (an inexact one moved four cones' 2 N state to the other of its two equilibria,
docs/contact.md "Two equilibria"); beside a Coulomb bound its measures decide, as before.

Where a Coulomb bound has not settled after :data:`FIXED_POINT_SOLVES` solves under Aitken's factor, that
step's updates go on under Anderson's acceleration (:class:`Anderson`) for as many solves again (a pair whose
friction presses it harder as its bound grows makes the plain update diverge, and Aitken's one factor cannot
serve that pair and its oscillating neighbours at once: docs/contact.md, "A large coefficient"); the next step
starts under Aitken's again. A step whose bounds settle under Aitken's is solved as before, bit for bit.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

log = logging.getLogger("suture_fem")

#: Newton solves at most per load step (the slip bound's fixed point), and the reason a step fails with
#: when the bound has not settled by then.
FIXED_POINT_SOLVES = 30
NOT_SETTLED = "friction_bound_not_settled"
#: A fixed point's first solve stops at this fraction of the friction law's residual at its start (N; an inexact
#: solve in the sense of Eisenstat and Walker's forcing terms): the chord steps and the last solve finish it.
FORCING = 0.1
#: A chord step (the last factorisation, a residual, a back-substitution) follows an update of the bound that
#: shrank the law's residual by this factor at least; after any other update a full Newton solve, as without them.
CHORD_CONTRACTION = 0.5
#: A chord step only follows an update that moved the bound by at most this fraction of itself: the frozen-bound
#: Jacobian it reuses is the old bound's (a stuck plug pressed on from rest, mu 300: the bound went from 0 to
#: mu p, a chord step multiplied the law's residual by ten and the full solve after it did not converge).
CHORD_BOUND_CHANGE = 0.5
#: Aitken's relaxation factor is kept in this range (a factor above 1 extrapolates).
OMEGA_MIN, OMEGA_MAX = 0.01, 2.0
#: The largest Aitken factor of the cones' multipliers' update: Uzawa's plain update (1) converges at a rate
#: k / (k + kappa) where the tissue's local stiffness k exceeds kappa (0.96 per update measured at a
#: single cone's apex); the factor extrapolates such a mode up to 1 / (1 - rate).
UZAWA_OMEGA_MAX = 50.0
#: An update that reverses its entry's sign and keeps more than this fraction of its size swaps (:class:`Reversals`).
SWAP_CONTRACTION = 0.5
#: A pressed pair whose multiplier's update swaps (:class:`Reversals`) has its penalty doubled, up to
#: BOOST_MAX x kappa: the update moves the pair's error by k / (k + kappa), which is -1 or below where the
#: tissue's own stiffness k in a mode is -kappa / 2 or softer (docs/contact.md, "The multipliers that swap").
BOOST_MAX = 16.0


class Aitken:
    """Aitken's relaxation factor of a fixed-point iteration x <- x + omega r (Irons and Tuck 1969).

    omega_k = -omega_{k-1} r_{k-1} . (r_k - r_{k-1}) / |r_k - r_{k-1}|^2, kept in [OMEGA_MIN, ``largest``];
    the first update is plain (omega = 1).
    """

    def __init__(self, comm: Any, largest: float = OMEGA_MAX):
        """``comm``: the residuals' communicator (each rank holds its part)."""
        self.comm, self.largest = comm, largest
        self._last: np.ndarray | None = None
        self._omega = 1.0

    def factor(self, r: np.ndarray) -> float:
        """The factor for this update's residual ``r`` (this rank's part; collective)."""
        if self._last is not None and len(self._last) == len(r):
            dr = r - self._last
            num, den = self.comm.allreduce(np.array([float(np.sum(self._last * dr)), float(np.sum(dr * dr))]))
            if den > 0.0:
                self._omega = float(np.clip(-self._omega * num / den, OMEGA_MIN, self.largest))
        self._last = r
        return self._omega


#: Anderson's acceleration keeps this many last updates (its least squares' columns).
ANDERSON_DEPTH = 5


class Anderson:
    """Anderson's acceleration of the fixed point b <- b + r (Anderson 1965; Walker and Ni 2011).

    SIAM J Numer Anal 49:1715. The next iterate is b + r - (dB + dR) gamma, gamma minimising |W (r - dR gamma)|,
    dB and dR the differences of the last :data:`ANDERSON_DEPTH` iterates and their residuals, W the pairs' weights.

    Hand-written: scipy.optimize.anderson drives its own loop over a function, where here each evaluation is
    a Newton solve (or a chord step) inside the load stepping, on every rank.
    """

    def __init__(self, comm: Any, depth: int = ANDERSON_DEPTH):
        """``comm``: the residuals' communicator (each rank holds its part)."""
        self.comm, self.depth = comm, depth
        self._last: tuple[np.ndarray, np.ndarray] | None = None
        self._db: list[np.ndarray] = []
        self._dr: list[np.ndarray] = []

    def next(self, b: np.ndarray, r: np.ndarray, weight: np.ndarray) -> np.ndarray:
        """The next iterate from ``b`` and its residual ``r`` (this rank's parts; collective)."""
        if self._last is not None and len(self._last[0]) == len(b):
            self._db = [*self._db, b - self._last[0]][-self.depth:]
            self._dr = [*self._dr, r - self._last[1]][-self.depth:]
        else:  # a first update, or other pairs: no history to extrapolate from
            self._db, self._dr = [], []
        self._last = (b.copy(), r.copy())
        if not self._dr:
            return b + r
        dr, db = np.column_stack(self._dr), np.column_stack(self._db)
        wdr = dr * weight[:, None]
        normal, right = self.comm.allreduce(wdr.T @ wdr), self.comm.allreduce(wdr.T @ (weight * r))
        gamma = np.linalg.lstsq(normal, right, rcond=1e-12)[0]
        return b + r - (db + dr) @ gamma


class Reversals:
    """Which entries of a fixed-point update swap: reverse the sign of their last update without halving it.

    r_k r_{k-1} < 0 and |r_k| > :data:`SWAP_CONTRACTION` |r_{k-1}|: an entry that oscillates and does not settle
    (one that reverses while it shrinks fast converges).
    """

    def __init__(self, size: int):
        """No last update yet: nothing swaps."""
        self._last = np.zeros(size)

    def of(self, r: np.ndarray) -> np.ndarray:
        """The entries of this update ``r`` (this rank's) that swap."""
        out = (r * self._last < 0.0) & (np.abs(r) > SWAP_CONTRACTION * np.abs(self._last))
        self._last = r.copy()
        return out


def update_norms(comm: Any, forces: np.ndarray, moved: np.ndarray, now: np.ndarray) -> tuple[float, float]:
    """An update's residual, the 2-norm of ``forces`` (N), and its change, that of ``moved`` relative to ``now``'s.

    Every rank's parts (collective); the change is 0 where nothing moved, infinite from nothing.
    """
    squares, step, size = comm.allreduce(np.array([float(np.sum(forces * forces)), float(np.sum(moved * moved)),
                                                   float(np.sum(now * now))]))
    return math.sqrt(squares), (math.sqrt(step / size) if size > 0.0 else (0.0 if step == 0.0 else math.inf))


def settle(laws: Sequence[Any], solve_once: Callable[[float], tuple[bool, int, str]],
           tolerance: Callable[[], float], chord: Callable[[], bool] | None = None) -> tuple[bool, int, str]:
    """Newton solves, each law updated after each (``law.update(tolerance)``), until every law holds.

    A Coulomb bound is moved toward mu p until Coulomb's law holds to ``tolerance()`` (N); an augmented
    Lagrangian's multipliers toward the pressure until the penetration is below its target.

    ``solve_once(loose)`` is one Newton solve from the current state (converged, iterations, reason), stopped
    at a residual below ``loose`` (N) where that is above its own tolerance. With a Coulomb bound the first
    solve stops at :data:`FORCING` times the law's residual at its start. Between updates the state is
    moved by ``chord()`` (one step with the last factorisation; False: none taken) while each update shrinks
    the law's residual by :data:`CHORD_CONTRACTION` at least and moves the bound by at most
    :data:`CHORD_BOUND_CHANGE` of itself (:func:`_chord_on`; the Coulomb bounds' ``last_residual`` and
    ``last_change``, or with no Coulomb bound the augmented Lagrangians' multipliers'); the answer is always that of
    a last solve to the full tolerance after which the laws held. Returns the last solve's (converged, reason)
    with the Newton iterations summed; Coulomb bounds that have not settled after :data:`FIXED_POINT_SOLVES`
    solves (and as many chord steps) go on under Anderson's acceleration (the module's docstring) for as many
    again; not settled then, the step fails (:data:`NOT_SETTLED`), so the load stepping cuts it.
    """
    coulomb = [law for law in laws if law.mu > 0.0]
    loose = FORCING * max(law.residual() for law in coulomb) if coulomb and chord is not None else 0.0
    converged, its, reason = solve_once(loose)
    for law in laws:
        law.start()
    fixed = coulomb or laws  # what decides a chord step: a Coulomb bound where there is one, else the multipliers
    done, its, reason = _updates(laws, fixed, solve_once, tolerance, chord, (converged, its, reason), loose)
    if done is None and coulomb:
        log.info("friction bound not settled after %d solves: Anderson's acceleration for this step",
                 FIXED_POINT_SOLVES)
        for law in coulomb:
            law.accelerate()
        done, its, reason = _updates(laws, fixed, solve_once, tolerance, chord, (True, its, reason), 0.0)
    return (False, its, NOT_SETTLED) if done is None else (done, its, reason)


def _updates(laws: Sequence[Any], fixed: Sequence[Any], solve_once: Callable[[float], tuple[bool, int, str]],
             tolerance: Callable[[], float], chord: Callable[[], bool] | None, first: tuple[bool, int, str],
             loose: float) -> tuple[bool | None, int, str]:
    """The laws' updates and solves of :func:`settle` from the solve ``first`` (converged, iterations, reason).

    ``fixed``: the laws whose measures decide a chord step (:func:`_chord_on`).

    Returns (converged, iterations, reason); converged None when the laws have not settled after
    :data:`FIXED_POINT_SOLVES` solves, the last of them converged.
    """
    converged, its, reason = first
    solves, chords, solved, last = 1, 0, True, math.inf
    while solves <= FIXED_POINT_SOLVES:
        if not converged:
            return converged, its, reason
        held = all([law.update(tolerance()) for law in laws])  # every law updated, then judged
        now = max((law.last_residual for law in fixed), default=math.inf)
        log.debug("fixed point: %d solves (%d Newton its), %d chord steps; law residual %.2e N (tolerance %.2e N)",
                  solves, its, chords, now, tolerance())
        if held and solved and loose == 0.0:
            return converged, its, reason
        change = max((law.last_change for law in fixed), default=math.inf)
        take, last = _chord_on(chord, held, now, last, change, chords), now
        if take and chord():  # type: ignore[misc]
            chords, solved = chords + 1, False
            continue
        loose = 0.0
        converged, more, reason = solve_once(loose)
        its, solves, solved = its + more, solves + 1, True
    return (None if converged else False), its, NOT_SETTLED


def _chord_on(chord: Callable[[], bool] | None, held: bool, now: float, last: float, change: float,
              chords: int) -> bool:
    """Whether the next correction is a chord step.

    Not yet settled, the law's residual shrinking fast enough, the bound moved little enough for the last
    factorisation (of the bound before the update) to serve.
    """
    return (chord is not None and not held and now < CHORD_CONTRACTION * last and change <= CHORD_BOUND_CHANGE
            and chords < FIXED_POINT_SOLVES)
