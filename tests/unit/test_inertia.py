"""The inertia correction (suture_fem/solve/inertia.py) on small symmetric matrices factorised by MUMPS LDL^T."""

from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc

from suture_fem.solve import inertia


def _ksp_and_matrix(dense: np.ndarray):
    n = len(dense)
    A = PETSc.Mat().createAIJ([n, n], nnz=n, comm=PETSc.COMM_SELF)
    for i in range(n):
        for j in range(n):
            if dense[i, j] != 0.0 or i == j:  # the diagonal always stored, as in a Jacobian
                A.setValue(i, j, dense[i, j])
    A.assemble()
    A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("cholesky")
    pc.setFactorSolverType("mumps")
    ksp.setOperators(A, A)
    return ksp, A


def _diagonal(A) -> np.ndarray:
    return A.getDiagonal().getArray().copy()


def test_a_positive_definite_jacobian_is_left_alone():
    ksp, A = _ksp_and_matrix(np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 1.0], [0.0, 1.0, 2.0]]))
    assert inertia.correct(ksp, A) == (False, 0)
    assert inertia.negative_pivots(ksp) == 0
    assert _diagonal(A) == pytest.approx([4.0, 3.0, 2.0], abs=0)


def test_negative_pivots_are_shifted_away_by_the_smallest_tried_multiple_of_the_diagonal():
    # [[1, 3], [3, 1]] has eigenvalues 4 and -2: one negative pivot, gone once 1 + tau > 3; tau = 10 is the first
    dense = np.array([[1.0, 3.0, 0.0], [3.0, 1.0, 0.0], [0.0, 0.0, 5.0]])
    ksp, A = _ksp_and_matrix(dense)
    shifted, extra = inertia.correct(ksp, A)
    tau = inertia.FIRST_SHIFT * inertia.SHIFT_GROWTH ** (extra - 1)
    assert shifted and inertia.negative_pivots(ksp) == 0
    assert tau == pytest.approx(10.0)  # 1e-4 ... 1 leave it indefinite
    assert _diagonal(A) == pytest.approx(np.diag(dense) * (1 + tau))
    state = A.stateGet()
    x, b = A.createVecs()
    b.set(1.0)
    ksp.solve(b, x)  # solves with the shifted matrix; the solve itself leaves A as it is
    assert (A * x).getArray() == pytest.approx(np.ones(3))
    assert A.stateGet() == state


def test_a_shift_that_makes_the_matrix_singular_is_one_more_try():
    # [[1, 2], [2, 1]] + tau I has eigenvalues 3 + tau and tau - 1: singular at tau = 1, definite at tau = 10
    ksp, A = _ksp_and_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    shifted, extra = inertia.correct(ksp, A)
    assert shifted and inertia.negative_pivots(ksp) == 0
    assert _diagonal(A) == pytest.approx([11.0, 11.0])


def test_when_no_shift_helps_the_jacobian_is_restored():
    # eigenvalues 1 +- 1e4: the shifts change the diagonal, but the largest tried (1e3 |diag A|) stays below 1e4
    ksp, A = _ksp_and_matrix(np.array([[1.0, 1e4], [1e4, 1.0]]))
    shifted, extra = inertia.correct(ksp, A)
    assert not shifted and extra == inertia.MAX_TRIES + 1
    assert _diagonal(A) == pytest.approx([1.0, 1.0], abs=0)
    assert inertia.negative_pivots(ksp) == 1  # factorised again as it was


def test_a_failed_first_factorisation_is_left_to_the_solver():
    # singular: MUMPS fails (INFOG(1) < 0), nothing is shifted, and the solve reports the failed factorisation
    ksp, A = _ksp_and_matrix(np.array([[1.0, 1.0], [1.0, 1.0]]))
    assert inertia.correct(ksp, A) == (False, 0)
    assert inertia.negative_pivots(ksp) is None
    x, b = A.createVecs()
    b.set(1.0)
    ksp.solve(b, x)
    assert ksp.getConvergedReason() < 0


def test_the_next_correction_starts_near_the_last_shift_and_finds_the_same_smallest_one():
    # the first needs tau = 10 (six tries); on the same KSP a Jacobian that needs it again takes two (1, then 10),
    # and one that needs only tau = 1 (1 + tau > 1.5) takes three (1 has none, 0.1 has one, 1 again)
    dense = np.array([[1.0, 3.0, 0.0], [3.0, 1.0, 0.0], [0.0, 0.0, 5.0]])
    ksp, A = _ksp_and_matrix(dense)
    assert inertia.correct(ksp, A) == (True, 6)
    A.setDiagonal(PETSc.Vec().createWithArray(np.diag(dense).copy(), comm=PETSc.COMM_SELF))
    assert inertia.correct(ksp, A) == (True, 2)
    assert _diagonal(A) == pytest.approx(np.diag(dense) * 11.0)
    milder = np.array([[1.0, 1.5, 0.0], [1.5, 1.0, 0.0], [0.0, 0.0, 5.0]])
    _, B = _ksp_and_matrix(milder)
    assert inertia.correct(ksp, B) == (True, 3)
    assert inertia.negative_pivots(ksp) == 0
    assert _diagonal(B) == pytest.approx(np.diag(milder) * 2.0)  # the smallest: a fresh search finds tau = 1 too
    fresh, C = _ksp_and_matrix(milder)
    assert inertia.correct(fresh, C) == (True, 5)  # 1e-4 ... 1 from the start


def test_without_down_a_start_that_has_no_negative_pivot_is_taken_in_one_factorisation():
    # [[1, 1.5], [1.5, 1]] x (1 + tau) on the diagonal: definite from tau = 1 (1 + tau > 1.5) on the tenfold ladder;
    # from tau = 10 the search down finds 1 (10 and 1 have none, 0.1 has one, 1 again); without it, 10 in one
    milder = np.array([[1.0, 1.5, 0.0], [1.5, 1.0, 0.0], [0.0, 0.0, 5.0]])

    def search(start: int, down: bool) -> tuple[int | None, int]:
        ksp, A = _ksp_and_matrix(milder)
        original = A.getDiagonal()
        scale = original.copy()
        scale.abs()
        found = inertia.smallest_shift(ksp, A, original, scale, inertia.SHIFTS, start, down=down)
        assert inertia.negative_pivots(ksp) == 0
        assert _diagonal(A) == pytest.approx(np.diag(milder) * (1.0 + inertia.SHIFTS[found[0]]))
        return found

    assert inertia.SHIFTS[5] == pytest.approx(10.0)
    assert search(5, down=True) == (4, 4)
    assert search(5, down=False) == (5, 1)
    assert search(2, down=False) == (4, 3)  # below the smallest, the search goes up either way


def test_positive_definite_factorises_and_reads_the_inertia():
    ksp, A = _ksp_and_matrix(np.array([[4.0, 1.0], [1.0, 3.0]]))
    assert inertia.positive_definite(ksp, A) and inertia.negative_pivots(ksp) == 0
    ksp, A = _ksp_and_matrix(np.array([[1.0, 3.0], [3.0, 1.0]]))
    assert not inertia.positive_definite(ksp, A)


class _Contact:
    """The cones' contact as jacobian.exact_kept reads it: pairs' pressure and the outline's curvature there."""

    def __init__(self, pressure, curvature, convexified=True):
        self.p, self.curvature, self.convexified = np.asarray(pressure), np.asarray(curvature), convexified

    def search(self, _):
        return {"curvature": self.curvature}

    def pressure(self):
        return self.p


class _Problem:
    """A problem with the cones' contact; its state is read only to search."""

    def __init__(self, contact):
        from mpi4py import MPI

        self.cone_contact, self.comm = contact, MPI.COMM_SELF
        self.state = type("State", (), {"vector": PETSc.Vec().createSeq(1)})()


@pytest.mark.parametrize("pressure, curvature, tried", [
    ([1e4, 0.0], [0.0, 5e4], False),  # the node on the arc is open: nothing left out
    ([1e4, 2e3], [-5e4, 0.0], False),  # pressed on a concave arc and a segment: the convexified terms are exact
    ([1e4, 2e3], [0.0, 5e4], True),  # pressed on a convex arc: its softening is what the convexified terms drop
])
def test_the_exact_jacobian_is_tried_only_where_a_pressed_node_softens(pressure, curvature, tried):
    from suture_fem.solve import jacobian

    contact, seen = _Contact(pressure, curvature), []
    problem = _Problem(contact)
    kept = jacobian.exact_kept(problem, lambda: seen.append(contact.convexified), lambda: True)
    assert kept == tried and seen == ([False] if tried else [])  # assembled with the softening, once
    assert contact.convexified  # and the convexified terms back for the next assembly
    assert not jacobian.exact_kept(problem, lambda: None, lambda: False)  # indefinite (or not tried): not kept


def test_nothing_is_tried_without_convexified_cones():
    from suture_fem.solve import jacobian

    assert not jacobian.exact_kept(_Problem(None), lambda: pytest.fail("assembled"), lambda: True)
    contact = _Contact([1e4], [5e4], convexified=False)  # P1: the exact terms already
    assert not jacobian.exact_kept(_Problem(contact), lambda: pytest.fail("assembled"), lambda: True)
