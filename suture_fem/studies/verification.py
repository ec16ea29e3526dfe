"""Verification problems for the axisymmetric hyperelastic operator: is the discrete model solving the right equations?

Both problems are solved with the production pieces: the kinematics of :mod:`suture_fem.kinematics`
(F with the hoop term, dV = 2 pi r dr dz), the energies of :mod:`suture_fem.materials`, the residual
as the Gateaux derivative of the total energy (as :mod:`suture_fem.physics` builds it for the plain
displacement formulation) and the same quadrature degree. Only the mesh (a rectangle in (r, z)), the
loads and the boundary conditions differ. Newton's method here is a plain one started from the
interpolant of the exact solution: the solver's robustness is tested elsewhere, these problems test
the discretisation.

Manufactured solutions
----------------------
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

Telescopic shear of a tube
--------------------------
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
from collections.abc import Callable, Sequence
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

from suture_fem.physics import kinematics
from suture_fem.physics.effects import Effects, FormContext, Terms, elastic_terms
from suture_fem.physics.kinematics import THETA, R, Z
from suture_fem.physics.materials import Gent, Material, Yeoh, first_piola
from suture_fem.physics.problem import REGION_OF_TAG, quadrature_degree
from suture_fem.support import compat

#: An exact displacement written once for both UFL and numpy: (x, m) -> [u_r, u_z], with x = (r, z)
#: and m the module providing sin, cos, exp (``ufl`` or ``numpy``).
ExactField = Callable[[Any, Any], list[Any]]

#: Quadrature degree for loads and error norms (far above the integrands' polynomial parts).
HIGH_QUADRATURE = 10


# --------------------------------------------------------------------------------------------- mesh


def rectangle(comm: Any, radii: Sequence[float], z_range: tuple[float, float], cells_r: Sequence[int],
              cells_z: int, graded: bool = False) -> tuple[Any, Any]:
    """A triangulated rectangle in (r, z) with one cell tag per radial layer.

    Args:
        radii: layer boundaries r_0 < r_1 < ... (m); mesh lines fall on every boundary.
        cells_r: cells across each layer.
        graded: geometric spacing in r inside each layer (needs r_0 > 0), for fields that vary like 1/r.

    Returns:
        (mesh, cell_tags) with tag j + 1 on the cells of layer j.
    """
    n_r = int(sum(cells_r))
    mesh = dolfinx.mesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([1.0, 1.0])], [n_r, cells_z],
                                         dolfinx.mesh.CellType.triangle)
    x = mesh.geometry.x
    starts = np.concatenate([[0], np.cumsum(cells_r)])
    k = x[:, 0] * n_r  # position in cell widths
    r = np.empty_like(k)
    for j, n in enumerate(cells_r):
        inside = (k >= starts[j] - 1e-9) & (k <= starts[j + 1] + 1e-9)
        t = (k[inside] - starts[j]) / n
        lo, hi = radii[j], radii[j + 1]
        r[inside] = lo * (hi / lo) ** t if graded else lo + (hi - lo) * t
    x[:, 0] = r
    x[:, 1] = z_range[0] + (z_range[1] - z_range[0]) * x[:, 1]
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim, 0)
    n_cells = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
    mid = dolfinx.mesh.compute_midpoints(mesh, tdim, np.arange(n_cells, dtype=np.int32))[:, 0]
    layer = np.searchsorted(np.asarray(radii[1:-1]), mid) + 1
    tags = dolfinx.mesh.meshtags(mesh, tdim, np.arange(n_cells, dtype=np.int32), layer.astype(np.int32))
    return mesh, tags


# ------------------------------------------------------------------------------------- weak form


@dataclass
class Problem:
    """A verification problem: the production weak form on a rectangle, its unknown, residual and Jacobian.

    Attributes:
        W, state: space of the unknown and the unknown (displacement, or displacement and pressure).
        u, p: the displacement and (mixed) the pressure as UFL expressions of ``state``; p is None
            for the plain displacement formulation.
        W_u: the displacement (sub)space of W.
    """

    mesh: Any
    W: Any
    W_u: Any
    state: Any
    u: Any
    p: Any
    x: Any
    residual: Any
    jacobian: Any
    bcs: list[Any]

    @property
    def comm(self) -> Any:
        return self.mesh.comm

    def num_dofs(self) -> int:
        return int(self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs)

    def set_displacement(self, field: Callable[[np.ndarray], np.ndarray]) -> None:
        """Interpolate a numpy field into the displacement part of the state (the pressure is left)."""
        if self.p is None:
            self.state.interpolate(field)
            return
        V, to_state = self.W_u.collapse()
        g = dolfinx.fem.Function(V)
        g.interpolate(field)
        self.state.x.array[np.asarray(to_state)] = g.x.array
        self.state.x.scatter_forward()

    def displacement_values(self) -> tuple[np.ndarray, np.ndarray]:
        """(dof coordinates (n, 2), displacement values (n, 2)) at the owned displacement nodes."""
        if self.p is None:
            V, values = self.W, self.state.x.array
        else:
            V, to_state = self.W_u.collapse()
            values = self.state.x.array[np.asarray(to_state)]
        n_owned = V.dofmap.index_map.size_local
        return V.tabulate_dof_coordinates()[:n_owned, :2], values.reshape(-1, 2)[:n_owned].copy()


def build(mesh: Any, cell_tags: Any, material_of_tag: dict[int, Material], degree: int,
          load: Callable[[Any, Any, Any], Any] | None, dirichlet: list[tuple[Any, Any, Any]],
          formulation: str = "displacement") -> Problem:
    """The production weak form on a verification mesh.

    The elastic terms come from :func:`suture_fem.effects.elastic_terms` (the plain displacement
    form, or the mixed displacement-pressure form of ``effects.incompressibility = "mixed"``) on the
    kinematics of :mod:`suture_fem.kinematics`, with the quadrature degree of
    :func:`suture_fem.physics.quadrature_degree`; residual = Gateaux derivative of the potential
    terms plus the pressure equation, Jacobian = its derivative.

    Args:
        material_of_tag: cell tag -> material; tags are those of :data:`suture_fem.physics.REGION_OF_TAG`
            (1 hypodermis, 2 dermis, 3 epidermis, 4 thread), one material per region.
        load: ``load(v, x, weight)`` -> UFL linear form of the external load (None: no load).
        dirichlet: (where, component or None, value) with ``where`` a boundary marker on (r, z), and
            ``value`` a callable of the dof coordinates (whole vector) or a number (one component).
    """
    effects = Effects(incompressibility=formulation)
    if effects.mixed:
        W = compat.mixed_space(mesh, degree, degree - 1)
        W_u = W.sub(0)
    else:
        W = W_u = compat.vector_space(mesh, degree)
    state = dolfinx.fem.Function(W, name="state")
    test = ufl.TestFunction(W)

    def displacement(w: Any) -> Any:
        return ufl.as_vector([w[0], w[1]]) if effects.mixed else w

    x = ufl.SpatialCoordinate(mesh)
    weight = kinematics.volume_weight(x)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags,
                     metadata={"quadrature_degree": quadrature_degree(degree)})
    region_tags: dict[str, tuple[int, ...]] = {}
    materials: dict[str, Material] = {}
    for tag, material in material_of_tag.items():
        region = REGION_OF_TAG[tag]
        region_tags[region] = region_tags.get(region, ()) + (tag,)
        materials[region] = material
    u, v = displacement(state), displacement(test)
    p, q = (state[2], test[2]) if effects.mixed else (None, None)
    ctx = FormContext(w=state, u=u, p=p, v=v, q=q, test=test, x=x, weight=weight, dx=dx, ds=None, materials=materials,
                      region_tags=region_tags)
    terms = Terms()
    elastic_terms(ctx, effects, terms)
    residual = ufl.derivative(sum(terms.potential.values()), state, test)
    for form in terms.residual.values():
        residual = residual + form
    if load is not None:
        residual = residual - load(v, x, weight)
    jacobian = ufl.derivative(residual, state, ufl.TrialFunction(W))
    bcs = []
    for where, component, value in dirichlet:
        facets = dolfinx.mesh.locate_entities_boundary(mesh, mesh.topology.dim - 1, where)
        if component is None:
            V = W_u.collapse()[0] if effects.mixed else W_u
            g = dolfinx.fem.Function(V)
            g.interpolate(value)
            if effects.mixed:
                dofs = dolfinx.fem.locate_dofs_topological((W_u, V), mesh.topology.dim - 1, facets)
                bcs.append(dolfinx.fem.dirichletbc(g, dofs, W_u))
            else:
                dofs = dolfinx.fem.locate_dofs_topological(W_u, mesh.topology.dim - 1, facets)
                bcs.append(dolfinx.fem.dirichletbc(g, dofs))
        else:
            sub = W_u.sub(component)
            dofs = dolfinx.fem.locate_dofs_topological(sub, mesh.topology.dim - 1, facets)
            bcs.append(dolfinx.fem.dirichletbc(PETSc.ScalarType(value), dofs, sub))
    return Problem(mesh=mesh, W=W, W_u=W_u, state=state, u=u, p=p, x=x, residual=residual, jacobian=jacobian,
                   bcs=bcs)


def solve(problem: Problem, step_tol: float = 1e-11, max_iterations: int = 30) -> int:
    """Newton's method (direct LU) from the current ``problem.state``; returns the iterations.

    Converged when a Newton correction is below ``step_tol`` times the solution (quadratic
    convergence then leaves an algebraic error far below any discretisation error measured here).
    """
    F_form, J_form = dolfinx.fem.form(problem.residual), dolfinx.fem.form(problem.jacobian)
    A = dolfinx.fem.petsc.create_matrix(J_form)
    b = dolfinx.fem.petsc.create_vector(F_form)
    ksp = PETSc.KSP().create(problem.comm)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    ksp.getPC().setFactorSolverType("mumps")
    x = compat.function_vector(problem.state)
    dx = x.copy()
    try:
        for it in range(1, max_iterations + 1):
            with b.localForm() as b_local:
                b_local.set(0.0)
            dolfinx.fem.petsc.assemble_vector(b, F_form)
            dolfinx.fem.petsc.apply_lifting(b, [J_form], bcs=[problem.bcs], x0=[x], scale=-1.0)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            dolfinx.fem.petsc.set_bc(b, problem.bcs, x, -1.0)
            A.zeroEntries()
            dolfinx.fem.petsc.assemble_matrix(A, J_form, bcs=problem.bcs)
            A.assemble()
            ksp.setOperators(A)
            ksp.solve(b, dx)
            x.axpy(-1.0, dx)
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            step, size = dx.norm(), x.norm()
            if not math.isfinite(step):
                raise RuntimeError("verification solve: the Newton correction is not finite")
            if step <= step_tol * size:
                return it
        raise RuntimeError(f"verification solve: no convergence in {max_iterations} Newton iterations "
                           f"(last correction {step:.3e} of a solution of norm {size:.3e})")
    finally:
        for obj in (A, b, ksp, dx):
            obj.destroy()


def body_force(material: Material, exact: ExactField, x: Any) -> Any:
    """B = -Div P(F(u*)) in cylindrical coordinates (see the module docstring), as a UFL vector."""
    u_star = ufl.as_vector(exact(x, ufl))
    P = first_piola(material, kinematics.deformation_gradient(u_star, x))

    def d(i: int, j: int, k: int) -> Any:  # d P_ij / d x_k, k = 0 (r) or 1 (z)
        return ufl.grad(P[i, j])[k]

    div_r = d(R, R, 0) + d(R, Z, 1) + (P[R, R] - P[THETA, THETA]) / x[0]
    div_z = d(Z, R, 0) + d(Z, Z, 1) + P[Z, R] / x[0]
    return -ufl.as_vector([div_r, div_z])


def _numpy_field(exact: ExactField) -> Callable[[np.ndarray], np.ndarray]:
    def field(x: np.ndarray) -> np.ndarray:
        return np.vstack([np.broadcast_to(c, x.shape[1]) for c in exact(x[:2], np)])

    return field


def _weighted_norm(problem: Problem, integrand: Any) -> float:
    """sqrt(int integrand 2 pi r dr dz) with the high quadrature degree (collective)."""
    dx = ufl.Measure("dx", domain=problem.mesh, metadata={"quadrature_degree": HIGH_QUADRATURE})
    form = dolfinx.fem.form(integrand * kinematics.volume_weight(problem.x) * dx)
    return math.sqrt(problem.comm.allreduce(dolfinx.fem.assemble_scalar(form), op=MPI.SUM))


def weighted_errors(problem: Problem, exact: ExactField) -> tuple[float, float]:
    """(L2, H1 seminorm) of u_h - u*, both weighted by 2 pi r; the H1 part includes (e_r / r)^2."""
    x = problem.x
    e = problem.u - ufl.as_vector(exact(x, ufl))
    return (_weighted_norm(problem, ufl.inner(e, e)),
            _weighted_norm(problem, ufl.inner(ufl.grad(e), ufl.grad(e)) + (e[0] / x[0]) ** 2))


def pressure_error(problem: Problem, material: Material, exact: ExactField) -> float:
    """Weighted L2 error of the mixed formulation's pressure against p* = U'(J(u*))."""
    x = problem.x
    J = ufl.variable(ufl.det(kinematics.deformation_gradient(ufl.as_vector(exact(x, ufl)), x)))
    p_star = ufl.diff(material.volumetric(J), J)
    return _weighted_norm(problem, (problem.p - p_star) ** 2)


@dataclass
class ManufacturedResult:
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
        dxh = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": HIGH_QUADRATURE})
        return ufl.inner(body_force(material, exact, x), v) * weight * dxh

    problem = build(mesh, mesh_tags, {tag: material}, degree, load, [
        (lambda x: (np.abs(x[0] - size) < tol) | (np.abs(x[1]) < tol) | (np.abs(x[1] - size) < tol), None,
         _numpy_field(exact)),
        (lambda x: np.abs(x[0]) < tol, 0, 0.0),
    ], formulation)
    problem.set_displacement(_numpy_field(exact))
    its = solve(problem)
    l2, h1 = weighted_errors(problem, exact)
    p_l2 = pressure_error(problem, material, exact) if problem.p is not None else None
    cells = comm.allreduce(mesh.topology.index_map(2).size_local)
    return ManufacturedResult(cells=cells, h=size / n, l2=l2, h1=h1, newton_iterations=its, pressure_l2=p_l2)


def observed_rates(h: Sequence[float], err: Sequence[float]) -> list[float]:
    """log(e_i / e_{i+1}) / log(h_i / h_{i+1}) for consecutive meshes."""
    return [math.log(err[i] / err[i + 1]) / math.log(h[i] / h[i + 1]) for i in range(len(h) - 1)]


# ------------------------------------------------------------------------------------ tube shear


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
        """Axial displacement w(R) = int_R^b gamma ds (m).

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
        return (np.abs(x[0] - a) < tol) | (np.abs(x[0] - b) < tol) | (np.abs(x[1]) < tol) | (np.abs(x[1] - height) < tol)

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
    """Relative 2 pi r-weighted L2 error of the displacement gradient (hoop term included) against the
    exact grad u = -gamma(R) e_z (x) e_r, with gamma in closed form (:func:`shear_strain_ufl`).
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
