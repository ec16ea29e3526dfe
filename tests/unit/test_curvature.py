"""The trust region's step completed along negative curvature (suture_fem/solve/curvature.py).

A = diag(-1, 2, 4), D = |diag A| = diag(1, 2, 4), shifted by lam = 2: A + 2 D = diag(1, 6, 12) is positive
definite, and its step p = -(A + 2 D)^-1 g for g = (0.1, 1, 1) is (-0.1, -1/6, -1/12), |p| = 0.2115, inside a
radius of 1. The model g.p + p.A p / 2 is unbounded below along e1 (curvature -1), so its minimiser on the ball
lies on the boundary; the completion goes at most to STRETCH |p| = 0.846.
"""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.solve import curvature

DIAG = np.array([-1.0, 2.0, 4.0])
G = np.array([0.1, 1.0, 1.0])
LAM = 2.0


def _setup():
    comm = MPI.COMM_SELF
    n = len(DIAG)
    A = PETSc.Mat().createAIJ((n, n), nnz=1, comm=comm)
    M = PETSc.Mat().createAIJ((n, n), nnz=1, comm=comm)
    for i, a in enumerate(DIAG):
        A.setValue(i, i, a)
        M.setValue(i, i, a + LAM * abs(a))
    A.assemble()
    M.assemble()
    ksp = PETSc.KSP().create(comm)
    ksp.setType("preonly")
    ksp.getPC().setType("cholesky")
    ksp.setOperators(M)
    ksp.setUp()
    scale = PETSc.Vec().createSeq(n, comm=comm)
    scale.setArray(np.abs(DIAG))
    g = scale.duplicate()
    g.setArray(G)
    p = scale.duplicate()
    p.setArray(-G / (DIAG + LAM * np.abs(DIAG)))
    return ksp, A, scale, g, p


def _model(p: np.ndarray) -> float:
    return float(G @ p + 0.5 * p @ (DIAG * p))


def test_an_interior_step_is_completed_to_the_radius_along_the_negative_curvature():
    ksp, A, scale, g, p = _setup()
    start = p.getArray().copy()
    norm, theta = curvature.to_boundary(ksp, A, scale, g, p, 1.0, lambda q: 0.0)
    q = p.getArray()
    reach = curvature.STRETCH * np.linalg.norm(start)
    assert reach < 1.0 and norm == pytest.approx(reach, rel=1e-12) and np.linalg.norm(q) == pytest.approx(reach)
    # the pencil's lowest eigenvalue; four inverse iterations from p, each shrinking the other components by 1/3
    assert theta == pytest.approx(-1.0, rel=5e-3)
    # the completion is along e1: z's other components, 1.7 and 0.8 times its first in p, are 1/81 of that after
    # four iterations (0.021 and 0.010), times tau = -0.7
    assert np.allclose(q[1:], start[1:], atol=0.02)
    assert q[0] < -0.75  # downhill: g_1 > 0, so the root with x < 0 has the lower model value
    assert _model(q) < _model(start) - 0.25


def test_a_completion_the_rest_of_the_model_refuses_is_not_taken():
    ksp, A, scale, g, p = _setup()
    start = p.getArray().copy()
    # the open pairs' penalty of the model: any move of x beyond 0.3 costs more than the curvature gains
    norm, theta = curvature.to_boundary(ksp, A, scale, g, p, 1.0,
                                        lambda q: 1e3 * max(abs(q.getArray(readonly=True)[0]) - 0.3, 0.0) ** 2)
    assert theta < 0.0 and norm == pytest.approx(np.linalg.norm(start), rel=1e-14)
    assert np.array_equal(p.getArray(), start)


def test_a_convex_model_or_a_step_on_the_boundary_is_left_alone():
    ksp, A, scale, g, p = _setup()
    start = p.getArray().copy()
    assert curvature.to_boundary(ksp, A, scale, g, p, 0.2, lambda q: 0.0) == (pytest.approx(0.2115, abs=1e-4), 0.0)
    assert np.array_equal(p.getArray(), start)  # |p| = 0.2115 >= 0.9 x 0.2: on the boundary already
    A.setValue(0, 0, 1.0)  # now convex
    A.assemble()
    norm, theta = curvature.to_boundary(ksp, A, scale, g, p, 1.0, lambda q: 0.0)
    assert theta > 0.0 and np.array_equal(p.getArray(), start)
