"""Energies against hand values, stress = dW/dF, and the small-strain limit of every material.

F is a dolfinx Constant, so each material's [W, P] expression is compiled once and evaluated at
many deformation gradients by changing the constant's value.
"""

from __future__ import annotations

import math

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from suture_fem.physics.materials import Gent, StVenantKirchhoff, Yeoh, first_piola
from suture_fem.support import compat

HYPODERMIS = Yeoh(c=(400.0, 1400.0), inv_d=(50e3, 50e3))
EPIDERMIS = Gent(mu=4000.0, jm=1.2, inv_d=50e3)
SUTURE = StVenantKirchhoff(young=1.5e9, poisson=0.4)


class Evaluator:
    """W(F) and P(F) = dW/dF of one material at numeric 3x3 F."""

    _mesh = None

    def __init__(self, material):
        if Evaluator._mesh is None:
            Evaluator._mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
        self.F = dolfinx.fem.Constant(Evaluator._mesh, np.eye(3))
        W = material.energy(self.F)
        P = first_piola(material, self.F)
        expr = ufl.as_vector([W] + [P[i, j] for i in range(3) for j in range(3)])
        self.expr = compat.expression(expr, np.array([[1 / 3, 1 / 3]]))

    def __call__(self, F: np.ndarray) -> tuple[float, np.ndarray]:
        self.F.value[:] = F
        vals = compat.eval_expression(self.expr, Evaluator._mesh, np.array([0], dtype=np.int32)).ravel()
        return float(vals[0]), vals[1:].reshape(3, 3)


@pytest.fixture(scope="module")
def ev():
    return {"yeoh": Evaluator(HYPODERMIS), "gent": Evaluator(EPIDERMIS), "svk": Evaluator(SUTURE)}


def shear(gamma: float) -> np.ndarray:
    """Simple shear in the (r, z) plane: J = 1, I1 = 3 + gamma^2."""
    F = np.eye(3)
    F[0, 2] = gamma
    return F


def test_yeoh_hand_values(ev):
    # simple shear gamma = 0.5: I1bar - 3 = 0.25 -> 400 * 0.25 + 1400 * 0.25^2 = 187.5 Pa
    assert ev["yeoh"](shear(0.5))[0] == pytest.approx(187.5, rel=1e-12)
    # uniform dilatation J = 1.1: I1bar = 3 -> 50e3 * 0.1^2 + 50e3 * 0.1^4 = 505 Pa
    s = 1.1 ** (1 / 3)
    assert ev["yeoh"](np.eye(3) * s)[0] == pytest.approx(505.0, rel=1e-10)


def test_gent_hand_values(ev):
    # simple shear gamma = 0.5: -(4000 * 1.2 / 2) ln(1 - 0.25 / 1.2)
    assert ev["gent"](shear(0.5))[0] == pytest.approx(-2400.0 * math.log(1 - 0.25 / 1.2), rel=1e-12)
    # J = 1.1 dilatation: 50e3 * ((1.21 - 1) / 2 - ln 1.1)
    s = 1.1 ** (1 / 3)
    assert ev["gent"](np.eye(3) * s)[0] == pytest.approx(50e3 * (0.105 - math.log(1.1)), rel=1e-10)


def test_gent_energy_grows_without_bound_at_the_locking_limit(ev):
    # I1bar - 3 = gamma^2 in simple shear; approach Jm = 1.2 from below
    w = [ev["gent"](shear(math.sqrt(1.2 * (1 - eps))))[0] for eps in (1e-2, 1e-4, 1e-6)]
    assert w[0] < w[1] < w[2]
    # W ~ -(mu Jm / 2) ln(eps): each factor 100 closer adds (mu Jm / 2) ln 100
    assert w[2] - w[1] == pytest.approx(2400.0 * math.log(100.0), rel=1e-6)


def test_svk_hand_value(ev):
    # uniaxial stretch 1.1: E = diag(0.105, 0, 0); W = (lambda / 2 + mu) 0.105^2
    lam = 1.5e9 * 0.4 / (1.4 * 0.2)
    mu = 1.5e9 / 2.8
    F = np.diag([1.1, 1.0, 1.0])
    assert ev["svk"](F)[0] == pytest.approx((lam / 2 + mu) * 0.105**2, rel=1e-12)


@pytest.mark.parametrize("name", ["yeoh", "gent", "svk"])
def test_stress_is_the_derivative_of_the_energy(ev, name):
    rng = np.random.default_rng(7)
    F = np.eye(3) + 0.2 * rng.standard_normal((3, 3))
    F[0, 1] = F[1, 0] = F[1, 2] = F[2, 1] = 0.0  # torsionless axisymmetric structure
    W0, P = ev[name](F)
    dF = rng.standard_normal((3, 3))
    h = 1e-6
    dW = (ev[name](F + h * dF)[0] - ev[name](F - h * dF)[0]) / (2 * h)
    # central difference: truncation O(h^2 W''') and roundoff O(eps W / h); both far below 1e-6 here
    assert dW == pytest.approx(np.sum(P * dF), rel=1e-6, abs=1e-9 * abs(W0))


@pytest.mark.parametrize(
    "name, material",
    [("yeoh", HYPODERMIS), ("gent", EPIDERMIS), ("svk", SUTURE)],
)
def test_small_strain_limit_is_linear_elasticity(ev, name, material):
    """P(I + eps H) / eps -> 2 mu sym(H) + (K - 2 mu / 3) tr(H) I as eps -> 0."""
    rng = np.random.default_rng(3)
    H = rng.standard_normal((3, 3))
    H[0, 1] = H[1, 0] = H[1, 2] = H[2, 1] = 0.0
    eps = 1e-7
    _, P = ev[name](np.eye(3) + eps * H)
    mu, K = material.shear_modulus, material.bulk_modulus
    sym = 0.5 * (H + H.T)
    linear = 2 * mu * sym + (K - 2 * mu / 3) * np.trace(H) * np.eye(3)
    # the first neglected term is O(eps) relative: allow 100 eps, far above it and far below any modulus error
    np.testing.assert_allclose(P / eps, linear, rtol=100 * eps, atol=100 * eps * np.abs(linear).max())


def test_moduli_follow_the_ansys_convention():
    # 1/d1 multiplies (J-1)^2, so K0 = 2/d1 = 100 kPa; the hypodermis' initial nu is about 0.496
    assert HYPODERMIS.bulk_modulus == 100e3
    assert HYPODERMIS.shear_modulus == 800.0
    K, mu = HYPODERMIS.bulk_modulus, HYPODERMIS.shear_modulus
    nu = (3 * K - 2 * mu) / (2 * (3 * K + mu))
    assert nu == pytest.approx(0.496, abs=5e-4)
