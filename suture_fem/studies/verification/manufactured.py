"""Manufactured solutions for the axisymmetric operator: body force, error norms, observed rates.

For an exact displacement u* (smooth, u*_r odd and u*_z even in r, so that it is smooth as a 3D
field of revolution), the body force is the strong-form residual b = -Div P(F(u*)) written in
cylindrical coordinates, derived symbolically by UFL:

    (Div P)_r = dP_rR/dR + dP_rZ/dZ + (P_rR - P_thTh) / R
    (Div P)_z = dP_zR/dR + dP_zZ/dZ + P_zR / R

(P is the first Piola-Kirchhoff stress dW/dF from ``ufl.diff``, components in the order r, theta, z).
Integrating the weak form  int P : dF(v) 2 pi R dR dZ  by parts gives exactly these terms, so with
u = u* on the Dirichlet boundary (u_r = 0 on the axis, where the natural condition carries the weight
R = 0) the discrete solution converges to u* at the rates of the element: k + 1 in L2 and k in H1
for degree k, measured in the 2 pi r-weighted norms (the energy norm includes the hoop term u_r / r).
The mixed formulation (Taylor-Hood P2/P1, pressure p = U'(J) in the tissue) has the same exact
displacement, the exact pressure p* = U'(J(u*)) and the same body force (P_iso + p* J F^-T = P).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI

from suture_fem.physics import kinematics
from suture_fem.physics.kinematics import THETA, R, Z
from suture_fem.physics.materials import Material, first_piola
from suture_fem.studies.verification.problem import HIGH_QUADRATURE, Problem, build, rectangle, solve

#: An exact displacement written once for both UFL and numpy: (x, m) -> [u_r, u_z], with x = (r, z)
#: and m the module providing sin, cos, exp (``ufl`` or ``numpy``).
ExactField = Callable[[Any, Any], list[Any]]


def body_force(material: Material, exact: ExactField, x: Any) -> Any:
    """B = -Div P(F(u*)) in cylindrical coordinates (see the module docstring), as a UFL vector."""
    u_star = ufl.as_vector(exact(x, ufl))
    P = first_piola(material, kinematics.deformation_gradient(u_star, x))

    def d(i: int, j: int, k: int) -> Any:  # d P_ij / d x_k, k = 0 (r) or 1 (z)
        return ufl.grad(P[i, j])[k]

    div_r = d(R, R, 0) + d(R, Z, 1) + (P[R, R] - P[THETA, THETA]) / x[0]
    div_z = d(Z, R, 0) + d(Z, Z, 1) + P[Z, R] / x[0]
    return -ufl.as_vector([div_r, div_z])


def numpy_field(exact: ExactField, dim: int = 2) -> Callable[[np.ndarray], np.ndarray]:
    """The exact field for dolfinx's interpolation: the first ``dim`` coordinates of x (3, n) in, (dim, n) out."""
    def field(x: np.ndarray) -> np.ndarray:
        return np.vstack([np.broadcast_to(c, x.shape[1]) for c in exact(x[:dim], np)])

    return field


def weighted_norm(problem: Problem, integrand: Any) -> float:
    """sqrt(int integrand w dV), w the volume weight (2 pi r in the section, 2 in the 3-D half model; collective)."""
    dx = ufl.Measure("dx", domain=problem.mesh, metadata={"quadrature_degree": HIGH_QUADRATURE})
    form = dolfinx.fem.form(integrand * kinematics.volume_weight(problem.x) * dx)
    return math.sqrt(problem.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))


def weighted_errors(problem: Problem, exact: ExactField) -> tuple[float, float]:
    """(L2, H1 seminorm) of u_h - u*, both weighted by 2 pi r; the H1 part includes (e_r / r)^2."""
    x = problem.x
    e = problem.u - ufl.as_vector(exact(x, ufl))
    return (weighted_norm(problem, ufl.inner(e, e)),
            weighted_norm(problem, ufl.inner(ufl.grad(e), ufl.grad(e)) + (e[0] / x[0]) ** 2))


def pressure_error(problem: Problem, material: Material, exact: ExactField) -> float:
    """Weighted L2 error of the mixed formulation's pressure against p* = U'(J(u*))."""
    x = problem.x
    J = ufl.variable(ufl.det(kinematics.deformation_gradient(ufl.as_vector(exact(x, ufl)), x)))
    p_star = ufl.diff(material.volumetric(J), J)
    return weighted_norm(problem, (problem.p - p_star) ** 2)


@dataclass
class ManufacturedResult:
    """One manufactured solve: mesh size, weighted errors (L2, H1; pressure L2 when mixed), Newton iterations."""

    cells: int
    h: float
    l2: float
    h1: float
    newton_iterations: int
    pressure_l2: float | None = None


def manufactured_solve(comm: Any, material: Material, tag: int, exact: ExactField, degree: int, n: int,
                       size: float, formulation: str = "displacement") -> ManufacturedResult:
    """Solve the manufactured problem on [0, size]^2 (the axis included) with n x n squares, two triangles each.

    Dirichlet u = u* on r = size, z = 0 and z = size; u_r = 0 on the axis; body force -Div P(u*).
    With the mixed formulation the exact pressure is p* = U'(J(u*)), which the body force already
    balances (P_iso + p* J F^-T is the full P), and its error is returned too.
    """
    mesh, tags = rectangle(comm, [0.0, size], (0.0, size), [n], n)
    mesh_tags = dolfinx.mesh.meshtags(mesh, 2, tags.indices, np.full_like(tags.values, tag))
    tol = 1e-9 * size

    def load(v: Any, x: Any, weight: Any) -> Any:
        # the same subdomain data as the elastic terms: dolfinx >= 0.9 requires one per integral type and form
        dxh = ufl.Measure("dx", domain=mesh, subdomain_data=mesh_tags, metadata={"quadrature_degree": HIGH_QUADRATURE})
        return ufl.inner(body_force(material, exact, x), v) * weight * dxh

    problem = build(mesh, mesh_tags, {tag: material}, degree, load, [
        (lambda x: (np.abs(x[0] - size) < tol) | (np.abs(x[1]) < tol) | (np.abs(x[1] - size) < tol), None,
         numpy_field(exact)),
        (lambda x: np.abs(x[0]) < tol, 0, 0.0),
    ], formulation)
    problem.set_displacement(numpy_field(exact))
    its = solve(problem)
    l2, h1 = weighted_errors(problem, exact)
    p_l2 = pressure_error(problem, material, exact) if problem.p is not None else None
    cells = comm.allreduce(mesh.topology.index_map(2).size_local)
    return ManufacturedResult(cells=cells, h=size / n, l2=l2, h1=h1, newton_iterations=its, pressure_l2=p_l2)


def observed_rates(h: Sequence[float], err: Sequence[float]) -> list[float]:
    """log(e_i / e_{i+1}) / log(h_i / h_{i+1}) for consecutive meshes."""
    return [math.log(err[i] / err[i + 1]) / math.log(h[i] / h[i + 1]) for i in range(len(h) - 1)]

