"""Contact patch test: a uniform pressure through a flat frictionless interface is transmitted exactly.

A cylinder 0 <= r <= R, 0 <= z <= H rests on a rigid flat surface z = 0 (frictionless, unilateral: the
frictionless thread's penalty law 1/2 kappa int <-u_z>^2 2 pi r ds) and carries a uniform pressure P on
its top. The exact small-strain state is uniform uniaxial stress: u_z = -P / kappa - P z / E,
u_r = nu P r / E (linear, so every Lagrange space holds it exactly, with the penalty's uniform
penetration P / kappa), and the contact pressure is P at every point of the interface. With the St
Venant-Kirchhoff cylinder and P / E = 1e-6 the geometric nonlinearity is far below the tolerance. The
mesh is distorted (interior nodes moved randomly by up to a quarter cell), so the test does not rest
on a regular pattern: the discrete contact pressure (the penalty's nodal force over the 2 pi
r-weighted lumped area) must equal P at every interface node to solver tolerance.
"""

from __future__ import annotations

import math
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI

from suture_fem.physics.materials import StVenantKirchhoff
from suture_fem.scene.schema import Params
from suture_fem.studies.verification.hertz import TOP, nodal_pressure
from suture_fem.studies.verification.problem import build, newton_options, solve

#: Facet tags of the cylinder's base (the contact) and its top (the load).
BASE = TOP
LOADED = 2


def patch_solve(n: int, degree: int, pressure: float = 1e-6, penalty: float = 100.0, seed: int = 1,
                comm: Any = MPI.COMM_WORLD) -> dict[str, float]:
    """The n x n distorted unit cylinder (E = 1, nu = 0.3) pressed onto the rigid plane; the pressure's errors.

    Returns ``worst``: the largest |p_i - P| / P over the base's nodes (off the axis), ``total``: the
    base's total force over P pi R^2, and the Newton iterations.
    """
    mesh = dolfinx.mesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([1.0, 1.0])], [n, n],
                                         dolfinx.mesh.CellType.triangle)
    x = mesh.geometry.x
    interior = (x[:, 0] > 1e-12) & (x[:, 0] < 1 - 1e-12) & (x[:, 1] > 1e-12) & (x[:, 1] < 1 - 1e-12)
    shift = np.random.default_rng(seed).uniform(-0.25 / n, 0.25 / n, size=(len(x), 2))
    x[interior, :2] += shift[interior]  # by local node index: a serial test
    tdim = mesh.topology.dim
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    cells = dolfinx.mesh.meshtags(mesh, tdim, np.arange(n_cells, dtype=np.int32), np.ones(n_cells, dtype=np.int32))
    found = [(dolfinx.mesh.locate_entities_boundary(mesh, tdim - 1, where), tag)
             for where, tag in ((lambda p: np.isclose(p[1], 0.0), BASE), (lambda p: np.isclose(p[1], 1.0), LOADED))]
    indices = np.concatenate([f for f, _ in found])
    order = np.argsort(indices)
    values = np.concatenate([np.full(len(f), t, np.int32) for f, t in found])[order]
    facets = dolfinx.mesh.meshtags(mesh, tdim - 1, indices[order].astype(np.int32), values)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facets, metadata={"quadrature_degree": 2 * degree + 2})
    kappa = penalty * n  # penalty x E / h
    problem = build(mesh, cells, {1: StVenantKirchhoff(young=1.0, poisson=0.3)}, degree,
                    lambda v, x, weight: -pressure * v[1] * weight * ds(LOADED),
                    [(lambda p: np.isclose(p[0], 0.0), 0, 0.0)],
                    potential=lambda ctx: 0.5 * kappa * ufl.conditional(ufl.lt(ctx.u[1], 0.0), ctx.u[1], 0.0) ** 2
                    * ctx.weight * ds(BASE))
    options = newton_options(max_iterations=30)
    options = type(options).internal(**{**options.as_dict(), "atol": 1e-9 * pressure,
                                        "petsc_options": Params.of({"snes_linesearch_type": "bt", "snes_stol": 1e-12})})
    # from resting on the plane (u_z < 0 everywhere: the penalty holds the cylinder from the first iteration)
    problem.set_displacement(lambda p: np.vstack([np.zeros(p.shape[1]), np.full(p.shape[1], -2 * pressure / kappa)]))
    iterations = solve(problem, options)
    closed = kappa * ufl.conditional(ufl.lt(problem.u[1], 0.0), -problem.u[1], 0.0)
    r, p = nodal_pressure(problem, closed, ds, BASE)
    worst = comm.allreduce(float(np.max(np.abs(p / pressure - 1.0), initial=0.0)), op=MPI.MAX)
    X = ufl.SpatialCoordinate(mesh)
    total = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(closed * 2 * math.pi * X[0] * ds(BASE))),
                           op=MPI.SUM)
    return {"worst": worst, "total": total / (pressure * math.pi), "iterations": float(iterations)}
