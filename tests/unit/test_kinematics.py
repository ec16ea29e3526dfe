"""The axisymmetric deformation gradient against deformations whose F is known in closed form."""

from __future__ import annotations

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI

from suture_fem.physics import kinematics
from suture_fem.support import compat


def test_deformation_gradient_of_a_known_field():
    # u_r = a r^2 + c z, u_z = b z + e r on r in [0.5, 1.5]; quadratic, so exact in P2
    a, b, c, e = 0.3, -0.2, 0.1, 0.4
    mesh = dolfinx.mesh.create_rectangle(MPI.COMM_SELF, [np.array([0.5, 0.0]), np.array([1.5, 1.0])], [3, 3])
    V = compat.vector_space(mesh, 2)
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: np.vstack([a * x[0] ** 2 + c * x[1], b * x[1] + e * x[0]]))
    x = ufl.SpatialCoordinate(mesh)
    F = kinematics.deformation_gradient(u, x)
    expr = ufl.as_vector([F[i, j] for i in range(3) for j in range(3)] + [x[0], x[1]])
    pts = np.array([[0.2, 0.3], [0.6, 0.1]])
    cells = np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32)
    vals = compat.eval_expression(compat.expression(expr, pts), mesh, cells).reshape(-1, 11)
    for row in vals:
        r, z = row[9], row[10]
        expected = np.array([[1 + 2 * a * r, 0, c], [0, 1 + (a * r**2 + c * z) / r, 0], [e, 0, 1 + b]])
        np.testing.assert_allclose(row[:9].reshape(3, 3), expected, rtol=1e-12, atol=1e-12)


def test_volume_weight_integrates_the_solid_of_revolution():
    # a ring r in [0.5, 1.5], z in [0, 1] has volume pi (1.5^2 - 0.5^2) * 1 = 2 pi
    mesh = dolfinx.mesh.create_rectangle(MPI.COMM_SELF, [np.array([0.5, 0.0]), np.array([1.5, 1.0])], [2, 2])
    x = ufl.SpatialCoordinate(mesh)
    vol = dolfinx.fem.assemble_scalar(dolfinx.fem.form(kinematics.volume_weight(x) * ufl.dx(domain=mesh)))
    assert abs(vol - 2 * np.pi) < 1e-12 * 2 * np.pi
