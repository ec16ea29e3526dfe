"""Manufactured solutions for the 3-D Cartesian operator (geometry.dimension = 3): observed rates against theory.

The exact field on the cube [0, L]^3 is smooth, non-polynomial in every coordinate, with strains of a few
per cent to 15 %; the body force is the symbolic -div P(u*) (suture_fem.studies.verification.manufactured_3d).
The material is the 2-D test's Yeoh form (the paper's hypodermis c10, c20 with 1/d1 = 1/d2 = 1 kPa, out of the
locking range of the plain displacement element). Rates of the finest pair of meshes, within the 2-D test's
tolerance 0.1: measured here P1 L2 1.998, H1 0.996 (n = 8, 16); P2 L2 2.995, H1 1.997 (n = 8, 16).
"""

from __future__ import annotations

import math

import pytest
from mpi4py import MPI

from suture_fem.physics.materials import Yeoh
from suture_fem.studies.verification.manufactured_3d import manufactured_solve_3d
from tests.verification.test_manufactured import assert_rates

L = 1e-3  # m
MATERIAL = Yeoh(c=(400.0, 1400.0), inv_d=(1000.0, 1000.0))
MESHES = (4, 8, 16)


def exact(x, m):
    """A smooth 3-D field of amplitude 0.03-0.06 L, coupling all three coordinates."""
    xi, eta, zeta = x[0] / L, x[1] / L, x[2] / L
    return [
        0.05 * L * m.sin(math.pi * eta) * m.cos(math.pi * zeta / 2),
        0.06 * L * m.sin(math.pi * xi) * (1 + 0.5 * zeta * zeta),
        0.04 * L * m.cos(math.pi * xi / 2) * m.sin(math.pi * eta) + 0.03 * L * xi * zeta,
    ]


def _rates(degree: int) -> None:
    runs = [manufactured_solve_3d(MPI.COMM_WORLD, MATERIAL, 1, exact, degree, n, L) for n in MESHES]
    assert_rates(runs, degree, f"yeoh P{degree} 3-D")


@pytest.mark.slow
def test_3d_p1_rates_match_theory():
    _rates(1)


@pytest.mark.long
def test_3d_p2_rates_match_theory():
    _rates(2)
