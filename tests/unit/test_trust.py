"""The trust region on the energy (suture_fem/solve/trust.py) on a two-unknown energy with a saddle.

E(x, y) = (x^2 - 1)^2 / 4 + TILT x + y^2 / 2 has two minima near x = -1 and x = +1 and a saddle near x = TILT
(the roots of x^3 - x + TILT). From (0, 0.5) the Hessian is indefinite (E_xx = -1): Newton's iteration on the
gradient goes to the saddle, the trust region to the minimum downhill, x near -1.
"""

from __future__ import annotations

import zlib
from types import SimpleNamespace

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.outputs.results import SolverRecord
from suture_fem.physics.effects.cone_contact import ConeContact
from suture_fem.physics.effects.cone_model import GapModel
from suture_fem.physics.effects.pattern import ConeLayout
from suture_fem.solve import trust
from suture_fem.solve.memo import IterateMemo
from suture_fem.solve.records import RampResult, Timings

TILT = 0.01


def energy(v: np.ndarray) -> float:
    x, y = v
    return (x * x - 1.0) ** 2 / 4.0 + TILT * x + y * y / 2.0


def gradient(v: np.ndarray) -> np.ndarray:
    x, y = v
    return np.array([x ** 3 - x + TILT, y])


def hessian(v: np.ndarray) -> np.ndarray:
    return np.array([[3.0 * v[0] ** 2 - 1.0, 0.0], [0.0, 1.0]])


class _Fake:
    """What TrustRegion uses of a NewtonSolver, on E above or ``energy`` (the identity reduction, one process).

    ``energy``: (E, its gradient, its Hessian) of the unknowns, or None for E above.
    """

    def __init__(self, start: tuple[float, ...], forbidden_below: float = -np.inf, energy: tuple | None = None):
        comm = MPI.COMM_SELF
        size = len(start)
        self.E, self.gradient, self.hessian = energy or (globals()["energy"], gradient, hessian)
        self.forbidden_below = forbidden_below
        self.x = PETSc.Vec().createSeq(size, comm=comm)
        self.x.setArray(np.array(start, dtype=float))
        self.b = self.x.duplicate()
        self.b_full = self.x.duplicate()
        self.A_full = PETSc.Mat().createAIJ((size, size), nnz=size, comm=comm)  # MUMPS factorises AIJ, not dense
        self.A_full.setValues(range(size), range(size), np.eye(size))  # every entry in the pattern
        self.A_full.assemble()
        self.T = PETSc.Mat().createAIJ((size, size), nnz=1, comm=comm)
        for i in range(size):
            self.T.setValue(i, i, 1.0)
        self.T.assemble()
        self.A = self.A_full.ptap(self.T)  # reused by ptap, as NewtonSolver.A is
        values = np.array(start, dtype=float)  # the state's array, and its "PETSc vector" for restrict
        self.state = SimpleNamespace(x=SimpleNamespace(array=values, scatter_forward=lambda: None), vector=values)
        self.physics = SimpleNamespace(comm=comm, state=self.state)
        self.reduction = SimpleNamespace(T=self.T, restrict=self._restrict, expand=self._expand)
        self.memo = IterateMemo(comm)
        self.timings = Timings()
        self.options = SimpleNamespace(max_iterations=25, trust_region="on", inertia_correction=True)
        self.stops = SimpleNamespace(loose=0.0)
        self.guard = SimpleNamespace(anchor=lambda: None)
        self.objective_form = object()
        self.linear_solver = "mumps"
        self.largest_solve = 0
        self.floor = 0.0
        self.last_violation = None
        self.jacobian_current = self.factorised = False
        ksp = PETSc.KSP().create(comm)
        ksp.setType("preonly")
        ksp.getPC().setType("cholesky")
        ksp.getPC().setFactorSolverType("mumps")
        self.snes = SimpleNamespace(getKSP=lambda: ksp)
        self.ksp = ksp

    def _restrict(self, u, x) -> None:
        x.setArray(np.asarray(u, dtype=float))

    def _expand(self, x) -> None:
        self.state.x.array[:] = x.getArray(readonly=True)

    def _objective(self, snes, x) -> float:
        v = x.getArray(readonly=True).copy()
        self._expand(x)
        self.memo.at(x)
        self.memo.admissible = bool(v[0] >= self.forbidden_below)
        return self.E(v) if self.memo.admissible else 1e30

    def _residual(self, snes, x, b) -> None:
        b.setArray(self.gradient(x.getArray(readonly=True).copy()))

    def _assemble_full_jacobian(self) -> None:
        size = len(self.state.x.array)
        self.A_full.setValues(range(size), range(size), self.hessian(self.state.x.array))
        self.A_full.assemble()

    def round_off_floor(self, x) -> float:
        return 0.0

    def absolute_tolerance(self) -> float:
        return 1e-12


def _saddle_and_minimum() -> tuple[float, float]:
    roots = np.sort(np.roots([1.0, 0.0, -1.0, TILT]).real)
    return roots[1], roots[0]  # the saddle near TILT, the minimum near -1


def test_newton_on_the_gradient_goes_to_the_saddle_the_trust_region_to_the_minimum():
    saddle, minimum = _saddle_and_minimum()
    v = np.array([0.0, 0.5])
    for _ in range(20):  # plain Newton on the gradient, for contrast
        v = v - np.linalg.solve(hessian(v), gradient(v))
    assert v[0] == pytest.approx(saddle, abs=1e-12)

    fake = _Fake((0.0, 0.5))
    region = trust.TrustRegion(fake)
    ok, its, reason = region.solve()
    x = fake.x.getArray(readonly=True)
    assert ok and reason == "CONVERGED_FNORM_ABS"
    assert x[0] == pytest.approx(minimum, abs=1e-10) and abs(x[1]) < 1e-10
    assert np.all(np.linalg.eigvalsh(hessian(x)) > 0)  # a minimum
    assert fake.state.x.array[0] == pytest.approx(minimum, abs=1e-10)  # the state is the solution
    assert (region.record["solves"], region.record["converged"], region.record["iterations"]) == (1, 1, its)
    assert region.record["factorisations"] >= its  # at least one per Jacobian (shifted where indefinite)


def test_a_trial_outside_the_domain_shrinks_the_radius_and_is_never_kept():
    _, minimum = _saddle_and_minimum()
    fake = _Fake((0.0, 0.5), forbidden_below=-1.05)
    region = trust.TrustRegion(fake)
    region.delta = 50.0  # the first steps overshoot into x < -1.05
    tried, kept = [], []
    objective, residual = fake._objective, fake._residual
    fake._objective = lambda snes, x: tried.append(x.getArray(readonly=True)[0]) or objective(snes, x)
    fake._residual = lambda snes, x, b: kept.append(x.getArray(readonly=True)[0]) or residual(snes, x, b)
    ok, _, _ = region.solve()
    assert ok and fake.x.getArray(readonly=True)[0] == pytest.approx(minimum, abs=1e-10)
    assert min(tried) < -1.05  # trial states went outside ...
    assert min(kept) >= -1.05  # ... and every state the residual was taken at (the kept ones) is inside
    assert region.delta < 50.0


def test_after_solves_again_from_the_failed_solve_s_start():
    fake = _Fake((0.0, 0.5))
    region = trust.TrustRegion(fake)

    def failing(loose: float = 0.0):
        fake.state.x.array[:] = [7.0, 7.0]  # a failed solve leaves its last iterate
        return False, 3, "DIVERGED_LINE_SEARCH"

    ok, its, reason = region.after(failing)()
    assert ok and reason == "CONVERGED_FNORM_ABS" and its > 3
    assert fake.state.x.array[0] == pytest.approx(_saddle_and_minimum()[1], abs=1e-10)

    def converged(loose: float = 0.0):
        return True, 2, "CONVERGED_FNORM_ABS"

    assert region.after(converged)() == (True, 2, "CONVERGED_FNORM_ABS")  # a converged solve is left alone
    assert region.record["solves"] == 1


@pytest.mark.parametrize(("mode", "unilateral", "objective", "flags", "built"), [
    ("off", True, True, (False, False), False),
    ("auto", True, True, (False, False), True),  # frictionless or Coulomb cones at P1
    ("auto", True, True, (False, True), False),  # ... with the thread free too (nothing tied)
    ("auto", True, True, (True, True), True),  # ... at P2 or in 3-D (safeguarded)
    ("auto", False, True, (False, False), False),  # sliding cones
    ("auto", None, True, (False, False), False),  # no cones' contact
    ("on", None, True, (False, False), True),
    ("on", False, True, (False, True), True),
    ("on", None, False, (False, False), False),  # no energy to judge a step by
])
def test_which_scenes_get_the_trust_region(mode, unilateral, objective, flags, built):
    fake = _Fake((0.0, 0.5))
    fake.options.trust_region = mode
    safeguarded, thread_track = flags  # P2 or 3-D; the thread free in its track
    fake.physics.effects = SimpleNamespace(thread_track=thread_track)
    if unilateral is not None:
        fake.physics.cone_contact = SimpleNamespace(bilateral=not unilateral, safeguarded=safeguarded)
        fake.physics.mesh = SimpleNamespace(geometry=SimpleNamespace(dim=3))  # no gap model (2-D's)
    fake.objective_form = object() if objective else None
    assert (trust.TrustRegion.of(fake) is not None) is built


def test_a_start_outside_the_domain_is_refused_at_once():
    fake = _Fake((-2.0, 0.5), forbidden_below=-1.05)
    region = trust.TrustRegion(fake)
    assert region.solve() == (False, 0, "DIVERGED_FUNCTION_DOMAIN")
    assert region.record["factorisations"] == 0


def test_results_json_holds_the_counts_only_where_the_trust_region_solved():
    history = RampResult()
    history.trust_region = {"solves": 0, "converged": 0, "iterations": 0, "factorisations": 0}
    assert "trust_region" not in SolverRecord.from_history(history).as_dict()
    history.trust_region = {"solves": 2, "converged": 1, "iterations": 40, "factorisations": 90}
    assert SolverRecord.from_history(history).as_dict()["trust_region"] == history.trust_region


# A tissue node (unknowns u_r, u_z) pushed by FORCE onto a plane its cone (axial unknown t) carries: the gap
# phi = GAP + u_z - t, the pair's penalty KAPPA <-phi>^2 / 2 (weight 1, no multiplier), springs of stiffness 1.
GAP, FORCE, KAPPA = 0.1, 1.0, 1e4
NORMAL = np.array([0.0, 1.0, -1.0])  # d phi / d(u_r, u_z, t)


def _obstacle_energy(v: np.ndarray) -> float:
    return 0.5 * v @ v + FORCE * v[1] + 0.5 * KAPPA * max(-(GAP + v[1] - v[2]), 0.0) ** 2


def _obstacle_gradient(v: np.ndarray) -> np.ndarray:
    return v + np.array([0.0, FORCE, 0.0]) - KAPPA * max(-(GAP + v[1] - v[2]), 0.0) * NORMAL


def _obstacle_hessian(v: np.ndarray) -> np.ndarray:
    closed = GAP + v[1] - v[2] <= 0.0  # a touching node holds (touch_holds), as the P2 cones' do
    return np.eye(3) + (KAPPA * np.outer(NORMAL, NORMAL) if closed else 0.0)


class _Obstacle:
    """What GapModel uses of a ConeContact, for the node and plane above (one pair, one cone, one process).

    Its pressure law and its split of the scattered values are ConeContact's own.
    """

    _pressure = ConeContact._pressure
    moves = ConeContact.moves

    def __init__(self, move):
        self.comm = MPI.COMM_SELF
        self.pairs, self.kappa, self.touch_holds, self.bilateral = 1, KAPPA, True, False
        self.penalty, self.near = np.full(1, KAPPA), np.zeros(1, dtype=bool)
        self.weight, self.multiplier = np.ones(1), np.zeros(1)
        self.dofs, self.cone, self.cone_dofs = np.array([[0, 1]]), np.array([0]), [np.array([2])]
        self._layout = ConeLayout(self.dofs, self.cone, self.cone_dofs)
        self._local = PETSc.Vec().createSeq(3, comm=self.comm)
        index = PETSc.IS().createGeneral(np.arange(3, dtype=PETSc.IntType), comm=self.comm)
        self._scatter = PETSc.Scatter().create(move, index, self._local, None)

    def search(self, state) -> dict:
        v = np.asarray(state)
        return {"phi": np.array([GAP + v[1] - v[2]]), "n": np.array([[0.0, 1.0]])}


def _obstacle_solve(with_gaps: bool) -> tuple[trust.TrustRegion, _Fake, int]:
    fake = _Fake((0.0, 0.0, 0.0), energy=(_obstacle_energy, _obstacle_gradient, _obstacle_hessian))
    region = trust.TrustRegion(fake)
    region.gaps = GapModel(_Obstacle(fake.x), fake.reduction) if with_gaps else None
    region.delta = 10.0  # beyond the solution: the radius does not hold the steps here, the plane does
    ok, its, reason = region.solve()
    assert ok and reason == "CONVERGED_FNORM_ABS"
    return region, fake, its


def test_an_open_pair_the_step_presses_joins_the_model():
    # the solution, on the closed branch: (1 + KAPPA N N^T) v = -FORCE e_z - KAPPA GAP N
    exact = np.linalg.solve(np.eye(3) + KAPPA * np.outer(NORMAL, NORMAL), -FORCE * np.eye(3)[1] - KAPPA * GAP * NORMAL)
    assert GAP + exact[1] - exact[2] < 0.0  # pressed
    _, with_gaps, its = _obstacle_solve(True)
    _, without, its_without = _obstacle_solve(False)
    assert np.allclose(with_gaps.x.getArray(), exact, atol=1e-12)
    assert np.allclose(without.x.getArray(), exact, atol=1e-12)
    # without the open pair in its model, every step that reaches the plane is refused: the node creeps up to it
    assert its <= 3 and its_without >= 4 * its, (its, its_without)


def test_the_gap_model_s_energy_is_the_pair_s_penalty_on_the_linearised_gap():
    fake = _Fake((0.0, 0.0, 0.0), energy=(_obstacle_energy, _obstacle_gradient, _obstacle_hessian))
    gaps = GapModel(_Obstacle(fake.x), fake.reduction)
    gaps.at(fake.state.x.array)
    assert gaps.open.tolist() == [True]
    step = fake.x.duplicate()
    for move in ([0.0, -0.05, 0.0], [0.3, -0.2, 0.05], [0.0, 0.1, -0.2]):  # short of the plane, past it, away
        step.setArray(move)
        change = gaps.change(step)
        assert change == pytest.approx([move[1] - move[2]], abs=1e-15)
        v = np.array(move)
        assert gaps.energy(change) == pytest.approx(_obstacle_energy(v) - 0.5 * v @ v - FORCE * v[1], abs=1e-12)
        assert gaps.pressed(change).tolist() == [GAP + change[0] <= 0.0]


def test_a_solve_that_meets_the_residual_s_rounding_ends_at_its_floor_there():
    """The residual carries a rounding of up to 1e-9 that no step removes (drawn from the state's bits), the floor
    eps ||A diag|x| || is modelled as 1e-8 |x| (0 at rest, where the solve starts: the first step of a ramp).
    Its floor at the start, 0, is below that rounding; at the solution, 1e-8, above it. Refusals at the rounding
    used to shrink the radius until the solve failed; the floor is now taken where they occur."""
    _, minimum = _saddle_and_minimum()
    fake = _Fake((0.0, 0.0))

    def rounded(v: np.ndarray) -> np.ndarray:
        digits = np.random.default_rng(zlib.crc32(v.tobytes())).uniform(-1.0, 1.0, 2)  # the same at the same state
        return gradient(v) + 1e-9 * digits

    fake.gradient = rounded
    fake.round_off_floor = lambda x: 1e-8 * x.norm()
    fake.absolute_tolerance = lambda: max(1e-12, fake.floor)
    region = trust.TrustRegion(fake)
    ok, its, reason = region.solve()
    assert ok and reason == "CONVERGED_FNORM_ABS"
    assert fake.x.getArray(readonly=True)[0] == pytest.approx(minimum, abs=1e-8)
    assert fake.floor == pytest.approx(1e-8 * abs(minimum), rel=1e-6)  # taken at the solution, not at rest
    assert region.delta > 1e-6  # the next solve starts from the radius before the rounding's refusals


def test_a_refused_step_is_tried_shorter_before_the_radius_shrinks(monkeypatch):
    """From (0, 0.5) with a radius of 50 the first steps overshoot into x < -1.05, outside the domain. The refused
    step is tried at half its length, then a quarter (energy evaluations only), and kept there where the energy
    falls as that shorter step's model predicts: the same minimum in fewer factorisations than without."""
    _, minimum = _saddle_and_minimum()
    counts = {}
    for shorter in ((), trust.SHORTER):
        monkeypatch.setattr(trust, "SHORTER", shorter)
        fake = _Fake((0.0, 0.5), forbidden_below=-1.05)
        region = trust.TrustRegion(fake)
        region.delta = 50.0
        events = []  # ("trial", x) at each energy evaluation, ("state", x) at each residual (a kept state's)
        objective, residual = fake._objective, fake._residual
        fake._objective = lambda snes, x, e=events, f=objective: e.append(("trial", x.getArray().copy())) or f(snes, x)
        fake._residual = lambda snes, x, b, e=events, r=residual: e.append(("state", x.getArray().copy())) or r(
            snes, x, b)
        ok, _, _ = region.solve()
        assert ok and fake.x.getArray(readonly=True)[0] == pytest.approx(minimum, abs=1e-10)
        counts[shorter] = region.record["factorisations"]
        outside = [k for k, (kind, v) in enumerate(events) if kind == "trial" and v[0] < -1.05]
        assert outside  # the overshoot happened
        if shorter:  # next: the same step at half its length, from the state it started at
            k = outside[0]
            start = [v for kind, v in events[:k] if kind == "state"][-1]
            assert events[k + 1][0] == "trial"
            assert events[k + 1][1] == pytest.approx(start + 0.5 * (events[k][1] - start), abs=1e-12)
    assert counts[trust.SHORTER] < counts[()]
