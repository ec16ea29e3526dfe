"""Manufactured solutions for the 3-D Cartesian operator (``geometry.dimension = 3``): body force, errors, rates.

The 3-D twin of :mod:`suture_fem.studies.verification.manufactured`: for an exact displacement u*(x, y, z)
the body force is b = -div P(F(u*)), F = I + grad u* (:func:`suture_fem.physics.kinematics.deformation_gradient`
on a 3-vector), P = dW/dF from ``ufl.diff``, derived symbolically by UFL. The problem is solved on the
cube [0, L]^3 (six tetrahedra per small cube) with u = u* on its whole boundary, by the production
weak form and Newton solver (:func:`~suture_fem.studies.verification.problem.build`), so the discrete
solution converges to u* at the element's rates: k + 1 in L2 and k in the H1 seminorm for degree k.
The 3-D weight (2, the half model's) multiplies both norms alike and drops out of the rates.
"""

from __future__ import annotations

from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

from suture_fem.physics import kinematics
from suture_fem.physics.materials import Material, first_piola
from suture_fem.studies.verification.manufactured import ExactField, ManufacturedResult, numpy_field, weighted_norm
from suture_fem.studies.verification.problem import HIGH_QUADRATURE, Problem, build, solve


def body_force_3d(material: Material, exact: ExactField, x: Any) -> Any:
    """B = -div P(F(u*)) (Cartesian: (div P)_i = dP_ij / dx_j), as a UFL vector."""
    u_star = ufl.as_vector(exact(x, ufl))
    return -ufl.div(first_piola(material, kinematics.deformation_gradient(u_star, x)))


def errors_3d(problem: Problem, exact: ExactField) -> tuple[float, float]:
    """(L2, H1 seminorm) of u_h - u* (weighted by the half model's 2, which the rates do not see)."""
    e = problem.u - ufl.as_vector(exact(problem.x, ufl))
    return weighted_norm(problem, ufl.inner(e, e)), weighted_norm(problem, ufl.inner(ufl.grad(e), ufl.grad(e)))


def manufactured_solve_3d(comm: Any, material: Material, tag: int, exact: ExactField, degree: int, n: int,
                          size: float) -> ManufacturedResult:
    """Solve the manufactured problem on [0, size]^3, n^3 small cubes (6 tetrahedra each); u = u* on the boundary."""
    mesh = dolfinx.mesh.create_box(comm, [np.zeros(3), np.full(3, size)], [n, n, n], dolfinx.mesh.CellType.tetrahedron)
    tdim = mesh.topology.dim
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = np.arange(n_cells, dtype=np.int32)
    mesh_tags = dolfinx.mesh.meshtags(mesh, tdim, cells, np.full(n_cells, tag, dtype=np.int32))

    def load(v: Any, x: Any, weight: Any) -> Any:
        dxh = ufl.Measure("dx", domain=mesh, subdomain_data=mesh_tags, metadata={"quadrature_degree": HIGH_QUADRATURE})
        return ufl.inner(body_force_3d(material, exact, x), v) * weight * dxh

    problem = build(mesh, mesh_tags, {tag: material}, degree, load,
                    [(lambda x: np.full(x.shape[1], True), None, numpy_field(exact, 3))])
    problem.set_displacement(numpy_field(exact, 3))
    its = solve(problem)
    l2, h1 = errors_3d(problem, exact)
    total = comm.allreduce(mesh.topology.index_map(tdim).size_local)
    return ManufacturedResult(cells=total, h=size / n, l2=l2, h1=h1, newton_iterations=its)
