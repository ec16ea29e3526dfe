"""The slip bound's fixed point (physics/effects/fixed_point.py): chord steps between updates, a last full solve.

A scalar model with no forms: the state x solves k x = f - b (the bound b a force against the pull), the
"pressure" is c x, and Coulomb's law asks b = mu c x. A full solve sets x exactly (or to a loose tolerance);
a chord step moves x by one step with a stale stiffness.
"""

import math

import numpy as np

from suture_fem.physics.effects import fixed_point
from suture_fem.physics.effects.fixed_point import settle
from suture_fem.physics.effects.friction import SlipBound

K, F, C, MU, TOL = 2.0, 1.0, 0.8, 0.3, 1e-12


class Comm:
    def allreduce(self, value, op=None):
        return value


class Model:
    """The state, its solves (full, loose, chord) counted, and one Coulomb law on it."""

    def __init__(self):
        self.x, self.solves, self.chords, self.looser = 0.0, 0, 0, []

    def residual(self):
        return K * self.x - (F - self.law.bound[0])

    def solve_once(self, loose=0.0):
        self.solves += 1
        self.looser.append(loose)
        target = (F - self.law.bound[0]) / K
        self.x = target + (0.5 * loose / K if loose else 0.0)  # a loose solve stops short, within its test
        return True, 3, "CONVERGED_FNORM_ABS"

    def chord(self):
        self.chords += 1
        self.x -= self.residual() / (1.1 * K)  # a stale stiffness
        return True


class Law(SlipBound):
    """A Coulomb law: the package's SlipBound (its updates), on the scalar model's pressure."""

    def __init__(self, model):
        self.comm, self.mu, self.model = Comm(), MU, model
        self.weight, self.bound = np.array([1.0]), np.array([0.0])

    def pressure(self):
        return np.array([C * self.model.x])


def _run(chord, bound=0.09):
    model = Model()
    model.law = law = Law(model)
    law.bound[:] = bound  # a previous step's bound, near this one's (0.107)
    ok, its, reason = settle([law], model.solve_once, lambda: TOL, model.chord if chord else None)
    return model, law, ok, its


def test_chord_steps_replace_the_full_solves_and_a_full_solve_ends_the_fixed_point():
    plain, _, ok_plain, its_plain = _run(chord=False)
    fast, law, ok, its = _run(chord=True)
    assert ok and ok_plain
    exact = MU * C * F / (K + MU * C)  # b = mu c (f - b) / k
    # both end on Coulomb's law to the tolerance (the bound updated once more after the last check)
    assert abs(plain.law.bound[0] - exact) < 1e-11 and abs(law.bound[0] - exact) < 1e-11
    assert fast.chords >= 2 and fast.solves < plain.solves and its < its_plain
    assert fast.looser[0] > 0.0 and fast.looser[-1] == 0.0  # a loose first solve, a full last one
    assert plain.looser == [0.0] * plain.solves  # without chord steps every solve is full, as before


def test_no_chord_step_after_an_update_that_moved_the_bound_by_more_than_half_of_it():
    _, law, ok, _ = _run(chord=True, bound=0.0)  # from rest: the first update sets the whole bound
    fast, _, _, _ = _run(chord=True)
    assert ok and fast.chords >= 2
    model = Model()
    model.law = law = Law(model)
    law.update = lambda tolerance: (setattr(law, "last_change", 1.0), setattr(law, "last_residual", 1.0), False)[2]
    settle([law], model.solve_once, lambda: TOL, model.chord)
    assert model.chords == 0 and model.solves == 2 * fixed_point.FIXED_POINT_SOLVES + 1  # Aitken's, Anderson's


def test_a_fixed_point_that_does_not_settle_fails_the_step_after_its_solves_under_both_accelerations():
    model = Model()
    model.law = law = Law(model)
    law.update = lambda tolerance: False  # never holds
    ok, _, reason = settle([law], model.solve_once, lambda: TOL, None)
    assert not ok and reason == fixed_point.NOT_SETTLED and law.accelerated
    assert model.solves == 2 * fixed_point.FIXED_POINT_SOLVES + 1
    law.start()  # the next step starts under Aitken's factor again
    assert not law.accelerated
    model.solves = 0  # and goes through both rounds again: Aitken's solves, then Anderson's
    ok, _, reason = settle([law], model.solve_once, lambda: TOL, None)
    assert not ok and reason == fixed_point.NOT_SETTLED and model.solves == 2 * fixed_point.FIXED_POINT_SOLVES + 1


class Locking(SlipBound):
    """Two pairs: one whose friction presses it harder as its bound grows (mu p = 1.25 b - 2.5: b = 10 repels the
    plain update), one whose pressure falls as its bound grows (mu p = 9 - 0.8 b: b = 5, the plain update swaps)."""

    def __init__(self):
        self.comm, self.mu = Comm(), 1.0
        self.weight, self.bound = np.ones(2), np.array([9.5, 1.0])

    def pressure(self):
        return np.array([1.25 * self.bound[0] - 2.5, 9.0 - 0.8 * self.bound[1]])


def test_anderson_settles_a_bound_that_aitken_s_one_factor_cannot():
    law, solves = Locking(), []

    def solve_once(loose=0.0):
        solves.append(loose)
        return True, 1, "CONVERGED_FNORM_ABS"

    ok, _, reason = settle([law], solve_once, lambda: 1e-10, None)
    assert ok and law.accelerated  # Aitken's 30 solves did not settle it, Anderson's did
    assert np.allclose(law.bound, [10.0, 5.0], rtol=0.0, atol=1e-9)
    assert len(solves) < 2 * fixed_point.FIXED_POINT_SOLVES + 1


class Multiplier:
    """An augmented Lagrangian's part of ConeContact (mu 0): x <= 0 held by p = <lambda + kappa x>, lambda -> p."""

    augmented, mu, KAPPA, TARGET = True, 0.0, 20.0, 1e-10

    def __init__(self, model):
        self.comm, self.model = Comm(), model
        self.multiplier = np.array([0.5 * F])  # a previous step's, short of this one's (F)
        self.last_residual = self.last_change = math.inf

    def start(self):
        self._aitken = fixed_point.Aitken(self.comm, 1.0)  # plain Uzawa: contracts by k / (k + kappa) an update

    def update(self, tolerance):
        x = self.model.x
        p = np.maximum(self.multiplier + self.KAPPA * x, 0.0)
        r, old = p - self.multiplier, self.multiplier
        if abs(x) > self.TARGET:
            self.multiplier = np.maximum(old + self._aitken.factor(r) * r, 0.0)
        self.last_residual = float(np.linalg.norm(r))
        self.last_change = float(np.linalg.norm(self.multiplier - old) / np.linalg.norm(self.multiplier))
        return abs(x) <= self.TARGET


class Pressed(Model):
    """The state under the pull and the multiplier's law: k x + <lambda + kappa x> = f (pressed)."""

    def residual(self):
        return K * self.x - F + max(self.law.multiplier[0] + self.law.KAPPA * self.x, 0.0)

    def solve_once(self, loose=0.0):
        self.solves += 1
        self.looser.append(loose)
        self.x = (F - self.law.multiplier[0]) / (K + self.law.KAPPA)
        return True, 3, "CONVERGED_FNORM_ABS"

    def chord(self):
        self.chords += 1
        self.x -= self.residual() / (1.1 * (K + self.law.KAPPA))
        return True


def test_an_augmented_lagrangians_multipliers_are_followed_by_chord_steps_and_a_full_solve_ends():
    runs = {}
    for chord in (False, True):
        model = Pressed()
        model.law = law = Multiplier(model)
        ok, its, _ = settle([law], model.solve_once, lambda: TOL, model.chord if chord else None)
        runs[chord] = (model, law, ok, its)
    (plain, _, ok_plain, its_plain), (fast, law, ok, its) = runs[False], runs[True]
    assert ok and ok_plain and abs(fast.x) <= law.TARGET and abs(plain.x) <= law.TARGET
    assert fast.chords >= 2 and fast.solves < plain.solves and its < its_plain
    assert fast.looser == [0.0] * fast.solves  # no Coulomb law: every solve full, the first one too
    assert abs(fast.x - (F - law.multiplier[0]) / (K + law.KAPPA)) < 1e-15  # the answer is a full solve's


def test_a_doubled_penalty_settles_multipliers_that_swap():
    # Two pressed nodes whose tissue tilts unstably (stiffness -10 in the mode (1, -1), 10 in (1, 1)), held by
    # the penalty kappa = 20: the method of multipliers moves the tilt's error by -10 / (-10 + 20) = -1 per update
    stiffness, kappa, force = np.array([[0.0, 10.0], [10.0, 0.0]]), 20.0, np.ones(2)

    def largest_gap(boosted: bool, updates: int = 60) -> tuple[float, np.ndarray]:
        multiplier, boost, reversals = np.array([0.3, 0.9]), np.ones(2), fixed_point.Reversals(2)
        for _ in range(updates):
            penalty = kappa * boost
            x = np.linalg.solve(stiffness + np.diag(penalty), force - multiplier)  # the solve under lambda
            r = penalty * x  # p - lambda, p = lambda + kappa x (pressed)
            multiplier = multiplier + r
            if boosted:  # ConeContact.update's rule
                swapped = reversals.of(r)
                boost[swapped] = np.minimum(fixed_point.BOOST_MAX, 2.0 * boost[swapped])
        return float(np.max(np.abs(x))), boost

    assert largest_gap(False)[0] > 1e-3 and largest_gap(False, 600)[0] > 1e-3  # a 2-cycle: its gap never falls
    gap, boost = largest_gap(True)
    assert gap < 1e-12  # settled ...
    assert np.all(boost > 1.0) and np.all(boost < fixed_point.BOOST_MAX)  # ... doubled until it stopped swapping
