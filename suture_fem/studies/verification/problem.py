"""The production weak form and Newton solver on a verification mesh: a rectangle in (r, z).

:func:`build` writes the residual with the production pieces: the elastic terms of
:func:`suture_fem.physics.effects.elastic_terms` (plain displacement, or the mixed
displacement-pressure form of ``effects.incompressibility = "mixed"``) on the kinematics of
:mod:`suture_fem.physics.kinematics`, the quadrature degree of
:func:`suture_fem.physics.forms.quadrature_degree`, and the residual as the Gateaux derivative of
the potential terms plus the residual terms (:meth:`suture_fem.physics.forms.FormContext.variation`).
:func:`solve` runs the production :class:`~suture_fem.solve.newton.NewtonSolver` (SNES, direct LU,
domain guard, round-off floor) on it; the boundary values, which are not zero here, enter through
the reduction's affine offset u = T x + g (:mod:`suture_fem.solve.reduction`). Only the mesh, the
loads and the boundary conditions differ from a scene's problem.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry.regions import REGION_OF_TAG
from suture_fem.physics import kinematics
from suture_fem.physics.constraints import Unknowns, classify_dofs
from suture_fem.physics.effects import Effects, elastic_terms
from suture_fem.physics.forms import FormContext, Terms, quadrature_degree
from suture_fem.physics.materials import Material
from suture_fem.scene.schema import Params, SolverSection
from suture_fem.solve.guard import DomainGuard
from suture_fem.solve.newton import NewtonSolver
from suture_fem.solve.records import Timings
from suture_fem.support import compat

#: Quadrature degree for loads and error norms (far above the integrands' polynomial parts).
HIGH_QUADRATURE = 10


def rectangle(comm: Any, radii: Sequence[float], z_range: tuple[float, float], cells_r: Sequence[int],
              cells_z: int, graded: bool = False) -> tuple[Any, Any]:
    """A triangulated rectangle in (r, z) with one cell tag per radial layer.

    Args:
        comm: the communicator of the mesh.
        radii: layer boundaries r_0 < r_1 < ... (m); mesh lines fall on every boundary.
        z_range: (z_min, z_max) (m).
        cells_r: cells across each layer.
        cells_z: cells along z.
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


@dataclass
class Problem:
    """A verification problem: the production weak form on a rectangle, its unknown, residual and Jacobian.

    It is a :class:`~suture_fem.solve.reduction.Discrete` problem, so the production Newton solver
    solves it (:func:`solve`).

    Attributes:
        W, state: space of the unknown and the unknown (displacement, or displacement and pressure).
        W_u: the displacement (sub)space of W.
        u, p: the displacement and (mixed) the pressure as UFL expressions of ``state``; p is None
            for the plain displacement formulation.
        x: the SpatialCoordinate; cell_tags: the layer tags.
        materials: region -> material; region_tags: region -> its cell tags (the same on every rank).
        residual, jacobian: UFL forms; bcs: the Dirichlet conditions (values not necessarily zero).
        unknowns: the dofs SNES solves for (every dof no condition fixes).
    """

    mesh: Any
    W: Any
    W_u: Any
    state: Any
    u: Any
    p: Any
    x: Any
    cell_tags: Any
    materials: dict[str, Material]
    region_tags: dict[str, tuple[int, ...]]
    degree: int
    residual: Any
    jacobian: Any
    bcs: list[Any]
    unknowns: Unknowns
    rigid_displacement: Any = None
    _compiled: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def comm(self) -> Any:
        """The mesh's communicator."""
        return self.mesh.comm

    def form(self, name: str) -> Any:
        """The compiled form ``residual`` or ``jacobian``, compiled once."""
        if name not in self._compiled:
            self._compiled[name] = dolfinx.fem.form(getattr(self, name))
        return self._compiled[name]

    def sync(self) -> None:
        """Nothing to do: ``u`` and ``p`` are views of ``state``."""

    def num_dofs(self) -> int:
        """Size of the unknown's space."""
        return int(self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs)

    def guard(self) -> DomainGuard:
        """The production domain guard (J > 0, Gent margin > 0) on every layer."""
        ct = self.cell_tags  # every rank compiles the same checks (collective JIT), with its own cells
        cells = [(region, ct.indices[ct.values == t].astype(np.int32))
                 for region, tags in self.region_tags.items() for t in tags]
        return DomainGuard(self.mesh, self.x, kinematics.deformation_gradient(self.u, self.x), self.degree,
                           self.materials, cells)

    def dirichlet_values(self) -> Any:
        """G: a vector of the state's layout with the boundary values on the fixed dofs, zero elsewhere."""
        g = compat.function_vector(self.state).duplicate()
        g.set(0.0)
        dolfinx.fem.petsc.set_bc(g, self.bcs)
        g.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return g

    def set_displacement(self, values: Callable[[np.ndarray], np.ndarray]) -> None:
        """Interpolate a numpy field into the displacement part of the state (the pressure is left)."""
        if self.p is None:
            self.state.interpolate(values)
            return
        V, to_state = self.W_u.collapse()
        g = dolfinx.fem.Function(V)
        g.interpolate(values)
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
          formulation: str = "displacement", potential: Callable[[FormContext], Any] | None = None) -> Problem:
    """The production weak form on a verification mesh (see the module docstring).

    Args:
        mesh: the rectangle.
        cell_tags: its cell tags (one per layer).
        material_of_tag: cell tag -> material; tags are those of :data:`suture_fem.geometry.regions.REGION_OF_TAG`
            (1 hypodermis, 2 dermis, 3 epidermis, 4 thread), one material per region.
        degree: the displacement's polynomial degree.
        load: ``load(v, x, weight)`` -> UFL linear form of the external load (None: no load).
        dirichlet: (where, component or None, value) with ``where`` a boundary marker on (r, z), and
            ``value`` a callable of the dof coordinates (whole vector) or a number (one component).
        formulation: ``effects.incompressibility``: "displacement" or "mixed".
        potential: ``potential(ctx)`` -> a UFL energy added to the potential (a contact penalty), or None.
    """
    effects = Effects(incompressibility=formulation)
    if effects.mixed:
        W = compat.mixed_space(mesh, degree, degree - 1)
        W_u = W.sub(0)
    else:
        W = W_u = compat.vector_space(mesh, degree)
    state = dolfinx.fem.Function(W, name="state")
    ctx = _context(mesh, cell_tags, material_of_tag, degree, state, effects.mixed)
    terms = Terms()
    elastic_terms(ctx, effects, terms)
    if load is not None:
        terms.residual["load"] = -load(ctx.v, ctx.x, ctx.weight)
    if potential is not None:
        terms.potential["extra"] = potential(ctx)
    residual, jacobian = terms.residual_and_jacobian(ctx)  # as build_physics does
    bcs = [_dirichlet_bc(mesh, W_u, effects.mixed, *condition) for condition in dirichlet]
    return Problem(mesh=mesh, W=W, W_u=W_u, state=state, u=ctx.u, p=ctx.p, x=ctx.x, cell_tags=cell_tags,
                   materials=ctx.materials, region_tags=ctx.region_tags, degree=degree, residual=residual,
                   jacobian=jacobian, bcs=bcs,
                   unknowns=classify_dofs(W, bcs))


def _context(mesh: Any, cell_tags: Any, material_of_tag: dict[int, Material], degree: int, state: Any,
             mixed: bool) -> FormContext:
    """The production form context on the rectangle: regions from the tags, no facet measure."""
    test = ufl.TestFunction(state.function_space)

    def displacement(w: Any) -> Any:
        return ufl.as_vector([w[0], w[1]]) if mixed else w

    x = ufl.SpatialCoordinate(mesh)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags,
                     metadata={"quadrature_degree": quadrature_degree(degree)})
    region_tags: dict[str, tuple[int, ...]] = {}
    materials: dict[str, Material] = {}
    for tag, material in material_of_tag.items():
        region = REGION_OF_TAG[tag]
        region_tags[region] = region_tags.get(region, ()) + (tag,)
        materials[region] = material
    p, q = (state[2], test[2]) if mixed else (None, None)
    return FormContext(w=state, u=displacement(state), p=p, v=displacement(test), q=q, test=test, x=x,
                       weight=kinematics.volume_weight(x), dx=dx, ds=None, materials=materials,
                       region_tags=region_tags)


def _dirichlet_bc(mesh: Any, W_u: Any, mixed: bool, where: Any, component: int | None, value: Any) -> Any:
    """One Dirichlet condition on the boundary facets ``where`` marks: the whole displacement, or one component."""
    fdim = mesh.topology.dim - 1
    facets = dolfinx.mesh.locate_entities_boundary(mesh, fdim, where)
    if component is not None:
        sub = W_u.sub(component)
        dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
        return dolfinx.fem.dirichletbc(PETSc.ScalarType(value), dofs, sub)
    V = W_u.collapse()[0] if mixed else W_u
    g = dolfinx.fem.Function(V)
    g.interpolate(value)
    if mixed:
        return dolfinx.fem.dirichletbc(g, dolfinx.fem.locate_dofs_topological((W_u, V), fdim, facets), W_u)
    return dolfinx.fem.dirichletbc(g, dolfinx.fem.locate_dofs_topological(W_u, fdim, facets))


def newton_options(max_iterations: int = 30, step_tol: float = 1e-11) -> SolverSection:
    """The production solver's options for a verification solve.

    Full Newton steps ("basic": the start is the interpolant of the exact solution, close to the
    discrete one) and direct LU (MUMPS). Converged when a Newton correction is below ``step_tol`` times
    the solution (SNES's step test; quadratic convergence then leaves an algebraic error far below any
    discretisation error measured here), or when the residual reaches its round-off floor; the
    relative and absolute residual tests are off (0). Only the Newton fields are read; the stepping
    fields are those of a single step.
    """
    return SolverSection.internal(
        initial_step=1.0, min_step=1.0, max_step=1.0, grow=1.0, easy_iterations=max_iterations,
        max_iterations=max_iterations, rtol=0.0, atol=0.0, linear_solver="mumps",
        petsc_options=Params.of({"snes_linesearch_type": "basic", "snes_stol": step_tol}), gent_limit_fraction=1.0,
        inertia_correction=False,  # these problems factorise with LU: the correction needs LDL^T
    )


def solve(problem: Problem, options: SolverSection | None = None) -> int:
    """Solve with the production Newton solver from the current ``problem.state``; returns the iterations.

    The boundary values enter as the reduction's offset g. Raises RuntimeError when it does not
    converge (with SNES's reason).
    """
    offset = problem.dirichlet_values()
    newton = NewtonSolver(problem, options or newton_options(), Timings(), guard=problem.guard(), offset=offset)
    try:
        ok, its, reason = newton.solve()
    finally:
        newton.destroy()
        offset.destroy()
    if not ok:
        raise RuntimeError(f"verification solve: no convergence ({reason} after {its} Newton iterations)")
    return its
