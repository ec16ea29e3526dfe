"""Axisymmetric Hertz contact: a rigid sphere pressed into an elastic half-space, frictionless.

A sphere of radius R pressed a depth d into a half-space (Young's modulus E, Poisson's ratio nu) touches
it over the radius a = sqrt(R d) with the force F = 4/3 E / (1 - nu^2) a d and the pressure
p(r) = p0 sqrt(1 - r^2 / a^2), p0 = 3 F / (2 pi a^2) (Johnson, Contact Mechanics, 1985, section 4.2;
CONTACT.md's example). The half-space is a block 0 <= r <= L, -L <= z <= 0 with L = 1000 a (its top at
z = 0, its bottom held axially, its side free), meshed uniformly over 2 a next to the contact and
geometrically beyond; d / R = 1e-6 keeps the St Venant-Kirchhoff block's geometric nonlinearity far
below the errors measured.

What is computed with the package's own pieces: the production weak form and Newton solver
(:mod:`suture_fem.studies.verification.problem`) and the contact law of a frictionless thread
(:mod:`suture_fem.physics.effects.contact`): the penalty energy 1/2 kappa int <-g>^2 2 pi r ds with
kappa = factor x E / h, here with the gap to the sphere, g = (R - sqrt(R^2 - r^2)) - d - u_z, in place
of the thread's u_r. Measured: F as the penalty's total force, the contact radius as the bracket
between the last top-surface node in contact and the first one open, and the pressure profile (the
penalty's nodal force over its 2 pi r-weighted lumped area) against p(r) inside 0.9 a.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc
from scipy.optimize import brentq

from suture_fem.physics.materials import StVenantKirchhoff
from suture_fem.scene.schema import Params
from suture_fem.studies.verification.problem import build, newton_options, solve
from suture_fem.support import compat

#: Facet tag of the block's top surface (the contact side).
TOP = 1
#: The block's extent in contact radii.
EXTENT = 1000.0
#: The residual reached, relative to the sphere's force: the penalty's kink at the contact's edge (a
#: quadrature point in contact or not) stalls Newton at about 1e-6 of the force on these meshes (measured),
#: far below the discretisation errors measured here.
RESIDUAL = 1e-5


@dataclass(frozen=True)
class Hertz:
    """The closed form (CONTACT.md's E = 1, nu = 0.3; here R = 1e4, d = 1e-2: d / R = 1e-6, a = 10, F = 0.1465)."""

    radius: float = 1e4
    depth: float = 1e-2
    young: float = 1.0
    poisson: float = 0.3

    def contact_radius(self) -> float:
        """A = sqrt(R d)."""
        return math.sqrt(self.radius * self.depth)

    def force(self) -> float:
        """F = 4/3 E / (1 - nu^2) a d."""
        return 4.0 / 3.0 * self.young / (1.0 - self.poisson**2) * self.contact_radius() * self.depth

    def peak_pressure(self) -> float:
        """P0 = 3 F / (2 pi a^2)."""
        return 3.0 * self.force() / (2.0 * math.pi * self.contact_radius() ** 2)


def graded(n: int, fine: float, length: float) -> np.ndarray:
    """N + 1 node positions on [0, length]: n / 2 equal cells over [0, fine], then n / 2 growing geometrically."""
    m = n // 2
    h = fine / m
    if h * m >= length - fine:  # no growth needed
        return np.linspace(0.0, length, n + 1)
    q = brentq(lambda q: h * q * (q**m - 1.0) / (q - 1.0) - (length - fine), 1.0 + 1e-9, 10.0)
    outer = fine + np.cumsum(h * q ** np.arange(1, m + 1))
    return np.concatenate([np.linspace(0.0, fine, m + 1), outer[:-1], [length]])


def block(comm: Any, case: Hertz, n: int) -> tuple[Any, Any, Any]:
    """The block's mesh (n x n cells, graded toward the contact), its cell tags and its top's facet tags."""
    a = case.contact_radius()
    nodes = graded(n, 2.0 * a, EXTENT * a)
    mesh = dolfinx.mesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([1.0, 1.0])], [n, n],
                                         dolfinx.mesh.CellType.triangle)
    x = mesh.geometry.x
    unit = np.linspace(0.0, 1.0, n + 1)
    x[:, 0], x[:, 1] = np.interp(x[:, 0], unit, nodes), -np.interp(1.0 - x[:, 1], unit, nodes)
    tdim = mesh.topology.dim
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = dolfinx.mesh.meshtags(mesh, tdim, np.arange(n_cells, dtype=np.int32), np.ones(n_cells, dtype=np.int32))
    top = dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, lambda p: np.isclose(p[1], 0.0))
    facets = dolfinx.mesh.meshtags(mesh, tdim - 1, np.sort(top).astype(np.int32), np.full(len(top), TOP, np.int32))
    return mesh, cells, facets


def hertz_solve(case: Hertz, n: int, degree: int = 2, penalty: float = 100.0, steps: int = 4,
                comm: Any = MPI.COMM_WORLD) -> dict[str, float]:
    """Press the sphere in (``steps`` steps) on the ``n`` x ``n`` block; the measures over the closed form.

    ``penalty`` is kappa h / E with h the cells' size at the contact. Returns ``force`` (F over the
    closed form), ``pressure`` (the largest deviation from p(r) at the nodes inside 0.9 a, over p0),
    ``a_in`` and ``a_out`` (the last node in
    contact and the first open one, over a), ``h`` (the cell size at the contact over a) and the
    Newton iterations.
    """
    mesh, cells, facets = block(comm, case, n)
    a, R = case.contact_radius(), case.radius
    kappa = penalty * case.young / (4.0 * a / n)
    depth = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facets, metadata={"quadrature_degree": 2 * degree + 2})

    def closed(u: Any, x: Any) -> Any:  # <-g>: the penetration into the sphere
        g = (R - ufl.sqrt(R**2 - x[0] ** 2)) - depth - u[1]
        return ufl.conditional(ufl.lt(g, 0.0), -g, 0.0)

    problem = build(mesh, cells, {1: StVenantKirchhoff(young=case.young, poisson=case.poisson)}, degree, None,
                    [(lambda p: np.isclose(p[1], -EXTENT * a), 1, 0.0), (lambda p: np.isclose(p[0], 0.0), 0, 0.0)],
                    potential=lambda ctx: 0.5 * kappa * closed(ctx.u, ctx.x) ** 2 * ctx.weight * ds(TOP))
    options = newton_options(max_iterations=60)
    options = type(options).internal(**{**options.as_dict(), "atol": RESIDUAL * case.force(),
                                        "petsc_options": Params.of({"snes_linesearch_type": "bt", "snes_stol": 1e-12})})
    iterations = 0
    for k in range(1, steps + 1):
        depth.value = case.depth * k / steps
        iterations += solve(problem, options)
    x = ufl.SpatialCoordinate(mesh)
    force = comm.allreduce(dolfinx.fem.assemble_scalar(compat.form(kappa * closed(problem.u, x) * 2 * math.pi * x[0]
                                                                   * ds(TOP))), op=MPI.SUM)
    r, p = nodal_pressure(problem, kappa * closed(problem.u, x), ds, TOP)
    inside, outside = r[p > 0.0], r[p <= 0.0]
    a_in = comm.allreduce(float(inside.max(initial=0.0)), op=MPI.MAX)
    a_out = comm.allreduce(float(outside[outside > a_in].min(initial=np.inf)), op=MPI.MIN)
    inner = r < 0.9 * a  # the profile away from the edge, where p falls to 0 over one cell
    exact = case.peak_pressure() * np.sqrt(1.0 - (r[inner] / a) ** 2)
    deviation = comm.allreduce(float(np.max(np.abs(p[inner] - exact), initial=0.0)), op=MPI.MAX)
    return {"force": force / case.force(), "pressure": deviation / case.peak_pressure(), "a_in": a_in / a,
            "a_out": a_out / a, "h": 2.0 / (n // 2), "iterations": float(iterations)}


def nodal_pressure(problem: Any, pressure: Any, ds: Any, tag: int) -> tuple[np.ndarray, np.ndarray]:
    """(r, p) at the owned nodes of the flat surface z = 0 tagged ``tag``, off the axis.

    P: ``pressure``'s nodal force over the 2 pi r-weighted lumped area (on the axis the weight vanishes).
    """
    V, mesh = problem.W, problem.mesh
    v, x = ufl.TestFunction(V), ufl.SpatialCoordinate(mesh)
    force = dolfinx.fem.petsc.assemble_vector(compat.form(pressure * v[1] * 2 * math.pi * x[0] * ds(tag)))
    area = dolfinx.fem.petsc.assemble_vector(compat.form(v[1] * 2 * math.pi * x[0] * ds(tag)))
    values = []
    for vec in (force, area):
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values.append(vec.array.reshape(-1, 2)[:, 1].copy())
        vec.destroy()
    n_owned = V.dofmap.index_map.size_local
    coords = V.tabulate_dof_coordinates()[:n_owned]
    top = np.flatnonzero(np.isclose(coords[:, 1], 0.0))
    r, f, A = coords[top, 0], values[0][top], values[1][top]
    keep = r > 1e-9 * np.max(coords[:, 0])
    return r[keep], f[keep] / A[keep]
