"""Telescopic shear of a tube: the exact incompressible solution and the computed one.

A tube R in [a, b] bonded to a rigid core (R = a) that is displaced along the axis, its outer surface
fixed. The deformation r = R, theta = Theta, z = Z + w(R) has

    F = [[1, 0, 0], [0, 1, 0], [gamma, 0, 1]],  gamma = w'(R),  J = 1,  I1 = I1bar = 3 + gamma^2.

For an incompressible isotropic material W(I1) the axial equilibrium d(R sigma_rz)/dR = 0 gives
sigma_rz = -f / (2 pi R) (f: axial force per unit length of tube carried from the core to the outer
surface), and sigma_rz = 2 W'(I1) gamma, so the local amount of shear solves the scalar equation

    2 W'(3 + gamma^2) |gamma| = f / (2 pi R),       w(R) = int_R^b |gamma(s)| ds.

Yeoh: 2 W' gamma = 2 gamma sum_i i c_i0 gamma^(2(i - 1)) (monotone for c_i0 >= 0; solved by bracketing).
Gent: 2 W' gamma = mu gamma / (1 - gamma^2 / Jm), so gamma = (sqrt(mu^2 + 4 tau^2 / Jm) - mu) Jm / (2 tau).
The radial equilibrium is carried by the hydrostatic pressure of the incompressible material. This is
Rivlin's telescopic (pure axial) shear of a tube (R. S. Rivlin, Large elastic deformations of
isotropic materials VI, Phil. Trans. R. Soc. A 242 (1949) 173-195); the closed form for Gent's
material is C. O. Horgan and G. Saccomandi, Pure axial shear of isotropic, incompressible
nonlinearly elastic materials with limiting chain extensibility, J. Elasticity 57 (1999) 307-319;
see also R. W. Ogden, Non-linear Elastic Deformations (1984), section 5.3. A layered tube uses each
layer's W' in its own radial range (the shear stress is continuous across a bonded interface, the
shear strain jumps).

The package's tissue energies are the compressible ANSYS forms: the isochoric part depends on I1bar
and the volumetric part U(J) has U'(1) = 0, so on this isochoric deformation P_zR = 2 W'(I1) gamma
exactly and the axial equation is the incompressible one. The radial equation is not satisfied
without a pressure: with a finite bulk modulus K the tube also moves radially and changes volume by
a relative amount of order mu gamma^2 / K, which shifts w(R) by the same relative order. The exact
incompressible profile is therefore approached as 1/d grows; the comparison is made at large 1/d
(and at the paper's 1/d, where the difference is the compressibility of the model, not an error).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI

from suture_fem.physics import kinematics
from suture_fem.physics.materials import Gent, Material, Yeoh
from suture_fem.studies.verification.problem import HIGH_QUADRATURE, Problem, build, rectangle, solve


def shear_stress(material: Material, gamma: np.ndarray | float) -> np.ndarray:
    """Tau = 2 W'(3 + gamma^2) gamma on the isochoric simple-shear state (Pa)."""
    gamma = np.asarray(gamma, dtype=float)
    g2 = gamma * gamma
    if isinstance(material, Yeoh):
        return 2.0 * gamma * sum((i + 1) * c * g2**i for i, c in enumerate(material.c))
    if isinstance(material, Gent):
        return material.mu * gamma / (1.0 - g2 / material.jm)
    raise TypeError(f"no axial-shear response for {type(material).__name__}")


def shear_strain(material: Material, tau: np.ndarray | float) -> np.ndarray:
    """The amount of shear gamma >= 0 carrying the shear stress tau >= 0 (inverse of :func:`shear_stress`)."""
    tau = np.asarray(tau, dtype=float)
    if isinstance(material, Gent):  # Horgan & Saccomandi (1999): a quadratic in gamma
        mu, jm = material.mu, material.jm
        safe = np.where(tau > 0, tau, 1.0)
        return np.where(tau > 0, (np.sqrt(mu * mu + 4.0 * safe**2 / jm) - mu) * jm / (2.0 * safe), 0.0)
    if not isinstance(material, Yeoh) or min(material.c) < 0:
        raise TypeError("the axial-shear inverse needs a Gent or a Yeoh material with c_i0 >= 0 (monotone response)")
    lo, hi = np.zeros_like(tau), tau / (2.0 * material.c[0])  # tau >= 2 c10 gamma when every c_i0 >= 0
    for _ in range(200):  # bisection to round-off: the response is monotone
        mid = 0.5 * (lo + hi)
        below = shear_stress(material, mid) < tau
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def shear_strain_ufl(material: Material, tau: Any) -> Any:
    """:func:`shear_strain` in closed form as a UFL expression (Gent; Yeoh with c10 and c20 only).

    Yeoh: 2 c10 gamma + 4 c20 gamma^3 = tau is a depressed cubic with one real root (Cardano):
    gamma = cbrt(A + D) - cbrt(D - A), A = tau / (8 c20), D = sqrt(A^2 + p^3 / 27), p = c10 / (2 c20).
    """
    if isinstance(material, Gent):
        mu, jm = material.mu, material.jm
        return (ufl.sqrt(mu * mu + 4.0 * tau**2 / jm) - mu) * jm / (2.0 * tau)
    if isinstance(material, Yeoh) and len(material.c) == 1:
        return tau / (2.0 * material.c[0])
    if isinstance(material, Yeoh) and len(material.c) == 2 and material.c[1] > 0:
        c10, c20 = material.c
        A = tau / (8.0 * c20)
        D = ufl.sqrt(A**2 + (c10 / (2.0 * c20)) ** 3 / 27.0)
        return (A + D) ** (1.0 / 3.0) - (D - A) ** (1.0 / 3.0)
    raise TypeError("a closed-form axial-shear strain needs Gent or a two-term Yeoh material")


#: Gauss-Legendre rule used to integrate gamma between neighbouring radii.
_GAUSS = np.polynomial.legendre.leggauss(12)


@dataclass(frozen=True)
class TubeShear:
    """Exact telescopic shear of a (layered) incompressible tube on a rigid core.

    Attributes:
        radii: r_0 = a (core surface) < r_1 < ... < r_n = b (fixed outer surface), m.
        materials: one per layer.
        force_per_length: f, the axial force per unit tube length carried by every cylinder R (N/m).
    """

    radii: tuple[float, ...]
    materials: tuple[Material, ...]
    force_per_length: float

    def gamma(self, r: np.ndarray | float) -> np.ndarray:
        """|dw/dR| at radius r (on an interface, the outer layer's value)."""
        r = np.asarray(r, dtype=float)
        layer = np.searchsorted(np.asarray(self.radii[1:-1]), r, side="right")
        tau = self.force_per_length / (2.0 * math.pi * r)
        out = np.empty_like(r)
        for j, material in enumerate(self.materials):
            mask = layer == j
            out[mask] = shear_strain(material, tau[mask])
        return out

    def w(self, r: np.ndarray | float) -> np.ndarray:
        """Axial displacement, int_R^b gamma ds (m).

        Composite Gauss-Legendre between the sorted query radii, the layer interfaces and 400
        geometrically spaced radii per layer: gamma is analytic inside a layer, so the sum is exact to
        round-off.
        """
        r = np.asarray(r, dtype=float)
        grid = [np.geomspace(lo, hi, 400) for lo, hi in zip(self.radii[:-1], self.radii[1:])]
        pts = np.unique(np.concatenate([np.clip(r.ravel(), self.radii[0], self.radii[-1]), *grid]))
        nodes, weights = _GAUSS
        lo, hi = pts[:-1, None], pts[1:, None]
        s = 0.5 * (hi - lo) * nodes[None, :] + 0.5 * (hi + lo)
        pieces = 0.5 * (hi[:, 0] - lo[:, 0]) * (self.gamma(s) @ weights)
        w_at = np.concatenate([np.cumsum(pieces[::-1])[::-1], [0.0]])
        return w_at[np.searchsorted(pts, np.clip(r, self.radii[0], self.radii[-1]))]

    @property
    def core_displacement(self) -> float:
        """W(a): the core's axial displacement (m)."""
        return float(self.w(self.radii[0]))


@dataclass
class TubeResult:
    """FE solution of the tube at its owned displacement nodes, with the exact profile there."""

    comm: Any
    r: np.ndarray
    z: np.ndarray
    u_r: np.ndarray
    u_z: np.ndarray
    w: np.ndarray
    core_displacement: float
    gradient_error: float
    cells: int
    dofs: int
    newton_iterations: int

    def axial_error(self, u_z: np.ndarray | None = None) -> float:
        """Max |u_z - w(R)| over every node, relative to the core displacement (collective).

        ``u_z`` replaces the computed field (e.g. by one extrapolated in the bulk modulus).
        """
        u_z = self.u_z if u_z is None else u_z
        local = float(np.max(np.abs(u_z - self.w), initial=0.0))
        return self.comm.allreduce(local, op=MPI.MAX) / self.core_displacement

    def radial_displacement(self) -> float:
        """Max |u_r| over every node, relative to the core displacement (0 in the exact solution)."""
        return self.comm.allreduce(float(np.max(np.abs(self.u_r), initial=0.0)), op=MPI.MAX) / self.core_displacement

    def profile(self, z: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R, FE u_z, exact w) at the owned nodes of the mesh line Z = z, sorted by R."""
        on = np.abs(self.z - z) < 1e-9 * max(float(np.max(self.r, initial=1.0)), 1e-300)
        order = np.argsort(self.r[on])
        return self.r[on][order], self.u_z[on][order], self.w[on][order]


def incompressible_limit(u_1: np.ndarray, k_1: float, u_2: np.ndarray, k_2: float) -> np.ndarray:
    """Extrapolate a field computed at bulk moduli k_1 < k_2 to 1/K = 0, assuming u(K) = u_inf + c / K."""
    return (k_2 * u_2 - k_1 * u_1) / (k_2 - k_1)


def tube_solve(comm: Any, exact: TubeShear, tags: Sequence[int], degree: int, cells_r: Sequence[int],
               cells_z: int, height: float) -> TubeResult:
    """Solve the tube with the production operator, for comparison of u with (0, w(R)).

    The core surface R = a is displaced to (0, w(a)), the outer surface R = b is fixed and the end
    faces Z = 0, Z = height carry the exact displacement (0, w(R)) (a slice of an infinitely long
    tube). Cells are graded geometrically in R inside each layer (w' varies like 1/R).
    """
    radii = exact.radii
    mesh, layer_tags = rectangle(comm, radii, (0.0, height), cells_r, cells_z, graded=True)
    values = np.asarray(tags, dtype=np.int32)[layer_tags.values - 1]
    cell_tags = dolfinx.mesh.meshtags(mesh, 2, layer_tags.indices, values)
    a, b = radii[0], radii[-1]
    tol = 1e-9 * b

    def on_boundary(x: np.ndarray) -> np.ndarray:
        radial = (np.abs(x[0] - a) < tol) | (np.abs(x[0] - b) < tol)
        return radial | (np.abs(x[1]) < tol) | (np.abs(x[1] - height) < tol)

    def exact_field(x: np.ndarray) -> np.ndarray:
        return np.vstack([np.zeros(x.shape[1]), exact.w(x[0])])

    problem = build(mesh, cell_tags, dict(zip(tags, exact.materials)), degree, None,
                    [(on_boundary, None, exact_field)])
    problem.set_displacement(exact_field)
    its = solve(problem)
    gradient_error = _tube_gradient_error(problem, exact, tags, cell_tags)
    xy, uh = problem.displacement_values()
    return TubeResult(
        comm=comm, r=xy[:, 0], z=xy[:, 1], u_r=uh[:, 0].copy(), u_z=uh[:, 1].copy(), w=exact.w(xy[:, 0]),
        core_displacement=exact.core_displacement, gradient_error=gradient_error,
        cells=comm.allreduce(mesh.topology.index_map(2).size_local),
        dofs=problem.num_dofs(), newton_iterations=its,
    )


def _tube_gradient_error(problem: Problem, exact: TubeShear, tags: Sequence[int], cell_tags: Any) -> float:
    """Relative 2 pi r-weighted L2 error of the displacement gradient (hoop term included).

    The exact gradient is grad u = -gamma(R) e_z (x) e_r, with gamma in closed form (:func:`shear_strain_ufl`).
    """
    x, u = problem.x, problem.u
    weight = kinematics.volume_weight(x)
    dx = ufl.Measure("dx", domain=problem.mesh, subdomain_data=cell_tags,
                     metadata={"quadrature_degree": HIGH_QUADRATURE})
    tau = exact.force_per_length / (2.0 * math.pi * x[0])
    g = ufl.grad(u)
    error, norm = 0, 0
    for tag, material in zip(tags, exact.materials):
        gamma = shear_strain_ufl(material, tau)
        mismatch = g[0, 0] ** 2 + g[0, 1] ** 2 + (g[1, 0] + gamma) ** 2 + g[1, 1] ** 2 + (u[0] / x[0]) ** 2
        error += mismatch * weight * dx(tag)
        norm += gamma**2 * weight * dx(tag)
    comm = problem.comm
    e2, n2 = (comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(f)), op=MPI.SUM) for f in (error, norm))
    return math.sqrt(e2 / n2)
