"""A rigid plug in an elastic tube with Coulomb friction: the contact terms against closed forms.

The tube a <= r <= b, 0 <= z <= H (axisymmetric) is pressed onto a rigid plug r < a by a pressure P on
its outer surface, whose axial displacement is held at 0; the plug is moved axially by d. The exact
small-strain solution (CONTACT.md) is independent of z: the radial part is Lame's with the plug's
surface held, u_r = A (r - a^2 / r), plane strain (no axial strain), so

    A = -P (1 - 2 nu) b^2 / (2 G (b^2 + (1 - 2 nu) a^2)),   sigma_zz = 2 lambda A,
    q = -sigma_rr(a) = 2 (1 - nu) P b^2 / (b^2 + (1 - 2 nu) a^2)     (the contact pressure);

the axial part is anti-plane shear, u_z = C ln(b / r), sigma_rz = -G C / r, carrying the plug's axial
force F = 2 pi G H C: while the plug sticks C = d / ln(b / a), so F = K d with the stick stiffness
K = 2 pi G H / ln(b / a); once the friction limit mu q is reached on the plug's surface it slides and
F = 2 pi a H mu q (the full-slip force), reached at d = F / K.

A tube of finite length carries that state only if its end faces carry the state's tractions: they are
applied there, (sigma_rz, sigma_zz) on z = H and their opposite on z = 0, from the closed form of the
case solved (stick: C from d; slip: C from the full-slip force). The solve then has the closed form as
its solution up to the discretisation, the penalty's compliance and the regularised slip; small
loads (P / G = 1e-3) make the St Venant-Kirchhoff tube's geometric nonlinearity negligible.

What is computed with the package's own pieces: the production weak form and Newton solver
(:mod:`suture_fem.studies.verification.problem`), the normal penalty kappa <-u_r> of a frictionless
thread (:mod:`suture_fem.physics.effects.contact`, here kappa = factor x E / h), and the Coulomb terms
and their fixed point (:class:`suture_fem.physics.effects.friction.ThreadFriction`, the plug as a rigid
surface moved by d). Measured: q as the contact pressure at the plug's surface nodes (the penalty's
nodal force over the lumped area), F as the sum of the friction forces.
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

from suture_fem.physics.effects.friction import ThreadFriction
from suture_fem.physics.materials import StVenantKirchhoff
from suture_fem.scene.schema import Params
from suture_fem.studies.verification.problem import build, newton_options, rectangle, solve
from suture_fem.support import compat

#: Facet tags of the tube's faces.
INNER, OUTER, BOTTOM, TOP = 1, 2, 3, 4


@dataclass(frozen=True)
class PlugInTube:
    """The closed form (CONTACT.md's example: a = 1, b = 10, H = 1, G = 1, nu = 0.3, P = 0.1, mu = 0.3)."""

    a: float = 1.0
    b: float = 10.0
    height: float = 1.0
    shear_modulus: float = 1.0
    poisson: float = 0.3
    pressure: float = 0.1
    mu: float = 0.3

    @property
    def lame(self) -> float:
        """Lame's first parameter lambda."""
        return 2.0 * self.shear_modulus * self.poisson / (1.0 - 2.0 * self.poisson)

    def radial_constant(self) -> float:
        """A of u_r = A (r - a^2 / r)."""
        nu, a, b = self.poisson, self.a, self.b
        return -self.pressure * (1 - 2 * nu) * b**2 / (2 * self.shear_modulus * (b**2 + (1 - 2 * nu) * a**2))

    def contact_pressure(self) -> float:
        """Q = 2 (1 - nu) P b^2 / (b^2 + (1 - 2 nu) a^2)."""
        nu, a, b = self.poisson, self.a, self.b
        return 2 * (1 - nu) * self.pressure * b**2 / (b**2 + (1 - 2 * nu) * a**2)

    def stick_stiffness(self) -> float:
        """K = 2 pi G H / ln(b / a)."""
        return 2 * math.pi * self.shear_modulus * self.height / math.log(self.b / self.a)

    def slip_force(self) -> float:
        """F = 2 pi a H mu q."""
        return 2 * math.pi * self.a * self.height * self.mu * self.contact_pressure()

    def force(self, d: float) -> float:
        """The plug's axial force at its displacement d: K d until the full-slip force, then that force."""
        return min(self.stick_stiffness() * d, self.slip_force())


def plug_solve(case: PlugInTube, d: float, cells_r: int, degree: int = 2, penalty: float = 1e3,
               slip: float | None = None, steps: int = 4, comm: Any = MPI.COMM_WORLD) -> dict[str, float]:
    """Solve the tube on a graded mesh with ``cells_r`` cells across (2 along z); the measured q and F.

    The tube is pressed onto the plug first, then the plug is moved to d (and the end faces' shear
    raised with it) in ``steps`` steps. ``penalty`` is kappa h / E; ``slip`` the regularising slip s
    (default 1e-3 of the full-slip displacement).
    Returns q over the closed form (the mean over the plug's nodes; ``q_worst`` the largest relative
    deviation of a node), F over the closed form, and the Newton iterations.
    """
    mesh, cell_tags = rectangle(comm, [case.a, case.b], (0.0, case.height), [cells_r], 2, graded=True)
    facets = _facet_tags(mesh, case)
    young = 2 * case.shear_modulus * (1 + case.poisson)
    h = case.a * ((case.b / case.a) ** (1.0 / cells_r) - 1.0)  # the first cell's radial size
    kappa = penalty * young / h
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facets, metadata={"quadrature_degree": 2 * degree + 2})
    force = case.force(d)
    shear = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))  # C of u_z = C ln(b / r), ramped with d
    problem = build(mesh, cell_tags, {1: StVenantKirchhoff(young=young, poisson=case.poisson)}, degree,
                    _loads(case, shear, ds), [(lambda x: np.isclose(x[0], case.b), 1, 0.0)],
                    potential=lambda ctx: 0.5 * kappa * ufl.conditional(ufl.lt(ctx.u[0], 0.0), ctx.u[0], 0.0) ** 2
                    * ctx.weight * ds(INNER))
    friction = _friction(problem, facets, ds, kappa, case.mu, slip if slip is not None else
                         1e-3 * case.slip_force() / case.stick_stiffness())
    problem.friction = friction  # the Newton solver adds its terms and settles its bound
    options = newton_options(max_iterations=60)
    # atol 1e-9 of the slip force: the residual's round-off floor here is about 2e-10 of it (4.9e-14 N on the
    # 4-cell rung, measured), where the line search can only fail (1e-12 of it failed there: DIVERGED_LINE_SEARCH)
    options = type(options).internal(**{**options.as_dict(), "atol": 1e-9 * case.slip_force(),
                                        "petsc_options": Params.of({"snes_linesearch_type": "bt", "snes_stol": 1e-11})})
    iterations = 0
    for k in range(steps + 1):  # the plug pressed on first (k = 0), then moved by d in steps
        friction.surface = d * k / steps
        shear.value = case.force(d * k / steps) / (2 * math.pi * case.shear_modulus * case.height)
        iterations += solve(problem, options)
    p = friction.pressure() / case.contact_pressure()
    state = compat.function_vector(problem.state)
    f_local = -float(np.sum(friction.forces(state)))  # the plug's axial force
    sums = comm.allreduce(np.array([float(len(p)), float(np.sum(p)), f_local]), op=MPI.SUM)
    worst = comm.allreduce(float(np.max(np.abs(p - 1.0), initial=0.0)), op=MPI.MAX)
    friction.destroy()
    return {"q": sums[1] / sums[0], "q_worst": worst, "force": sums[2] / force, "iterations": float(iterations)}


def _facet_tags(mesh: Any, case: PlugInTube) -> Any:
    """The tube's faces: plug (r = a), outer (r = b), bottom (z = 0), top (z = H)."""
    fdim = mesh.topology.dim - 1
    found = []
    for tag, where in ((INNER, lambda x: np.isclose(x[0], case.a)), (OUTER, lambda x: np.isclose(x[0], case.b)),
                       (BOTTOM, lambda x: np.isclose(x[1], 0.0)), (TOP, lambda x: np.isclose(x[1], case.height))):
        f = dolfinx.mesh.locate_entities_boundary(mesh, fdim, where)
        found.append((f, np.full(len(f), tag, dtype=np.int32)))
    indices = np.concatenate([f for f, _ in found])
    values = np.concatenate([v for _, v in found])
    order = np.argsort(indices)
    return dolfinx.mesh.meshtags(mesh, fdim, indices[order].astype(np.int32), values[order])


def _loads(case: PlugInTube, shear: Any, ds: Any) -> Any:
    """The outer pressure and the end faces' tractions of the closed form, u_z = ``shear`` ln(b / r)."""
    sigma_zz = 2.0 * case.lame * case.radial_constant()

    def load(v: Any, x: Any, weight: Any) -> Any:
        sigma_rz = -case.shear_modulus * shear / x[0]
        end = sigma_rz * v[0] + sigma_zz * v[1]
        return (-case.pressure * v[0] * weight * ds(OUTER) + end * weight * ds(TOP) - end * weight * ds(BOTTOM))

    return load


def _friction(problem: Any, facets: Any, ds: Any, kappa: float, mu: float, slip: float) -> ThreadFriction:
    """The Coulomb terms on the plug's surface (r = a), against the plug as a rigid surface."""
    V, mesh = problem.W, problem.mesh
    fdim = mesh.topology.dim - 1
    nodes = dolfinx.fem.locate_dofs_topological(V, fdim, facets.indices[facets.values == INNER])
    nodes = nodes[nodes < V.dofmap.index_map.size_local]
    v, x = ufl.TestFunction(V), ufl.SpatialCoordinate(mesh)
    b = dolfinx.fem.petsc.assemble_vector(compat.form(2 * math.pi * x[0] * v[1] * ds(INNER)))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    weight = b.array.reshape(-1, 2)[nodes, 1].copy()
    b.destroy()
    ur = problem.u[0]
    normal = compat.form(kappa * ufl.conditional(ufl.lt(ur, 0.0), -ur, 0.0) * v[0] * 2 * math.pi * x[0] * ds(INNER))
    blocks = np.asarray(V.dofmap.index_map.local_to_global(np.asarray(nodes, dtype=np.int32)), dtype=np.int64)
    dofs = (2 * blocks + 1).reshape(-1, 1)
    return ThreadFriction(mesh.comm, compat.function_vector(problem.state), dofs, weight, np.asarray(nodes), normal,
                          mu, slip)
