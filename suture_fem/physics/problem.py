"""Physics: the discrete problem of a scene, assembled from the effects it calls for.

The quasi-static problem is the stationarity of the total potential

    Pi(u) = sum_regions  int W_region(F(u)) 2 pi r dr dz  -  int t . u 2 pi r ds_pull

with t = F / (pi r_t^2) e_z on the thread's pulled end face, so that the 2 pi r-weighted integral of t
over the face is exactly the applied force F. The residual is the Gateaux derivative of Pi (plus the
non-potential terms of the called effects: the pressure equation of the mixed formulation, inertia,
damping) and the Jacobian its derivative again (UFL), so the tangent is exactly consistent.
Outer epidermis surface: u = 0. Axis: u_r = 0. Everything else traction-free.

Which terms exist is decided by :mod:`suture_fem.effects`: an effect a scene leaves off is never
built (``Physics.terms`` names what was built, ``Physics.left_out`` what was not and why).

Unknowns. ``state`` is the unknown Function: the displacement, or (mixed) displacement and pressure.
``u`` is always the displacement alone (a view of ``state`` in the mixed case, kept in sync by
:meth:`Physics.sync`), so outputs and the domain guard never see the pressure. What SNES solves for is
``T x`` (:class:`Unknowns`): every dof that is not fixed by a boundary condition, except that with a
rigid suture all of the suture's dofs are replaced by one axial motion d (u = (0, d) on every suture
node, the interface included) and its equation is the axial force balance of the suture.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.regions import REGION_OF_TAG
from suture_fem.physics import kinematics
from suture_fem.physics.effects import (
    Dynamics,
    Effects,
    FormContext,
    Terms,
    elastic_terms,
    gravity_term,
    mark_dofs,
    pull_term,
)
from suture_fem.physics.materials import Material, from_params
from suture_fem.scene.model import Scene
from suture_fem.support import compat

FREE, FIXED, RIGID = 0, 1, 2


def quadrature_degree(degree: int) -> int:
    """Quadrature degree for the (non-polynomial) hyperelastic integrands of a degree-k field."""
    return 2 * degree


@dataclass
class Unknowns:
    """Which local dofs of the state SNES solves for: FREE ones, FIXED (= 0) ones, RIGID (= d) ones.

    ``kind`` covers owned and ghost dofs of the state's space (unrolled); with a rigid suture the
    axial dofs of every suture node are RIGID and its radial dofs FIXED.
    """

    kind: np.ndarray
    n_owned: int
    rigid: bool

    def count(self, comm: Any) -> int:
        """Global number of unknowns SNES solves for (free dofs, plus d with a rigid suture)."""
        free = int(np.count_nonzero(self.kind[: self.n_owned] == FREE))
        return comm.allreduce(free) + (1 if self.rigid else 0)


@dataclass
class Physics:
    """The discrete problem of a scene: unknowns, forms, boundary conditions, load parameters.

    Attributes:
        tagged: the mesh and its tags; effects: what the scene calls for.
        W, state: space of the unknown and the unknown; V, u: displacement space and displacement.
        materials: region -> material.
        traction: the axial traction on the pulled face (Pa), set by the load stepping.
        gravity_factor: 0..1 multiplier of the weight (None without gravity).
        terms: residual contributions by effect (UFL forms); residual, jacobian: their sum and its derivative.
        bcs: Dirichlet conditions (zero values), in W.
        energy: strain energy (J); end_displacement: 2 pi r-weighted integral of u_z over the pulled face.
        unknowns: what SNES solves for; dynamics: time integration (None without inertia).
        left_out: what the scene does not call for, and why.
    """

    tagged: meshmod.TaggedMesh
    degree: int
    effects: Effects
    W: Any
    state: Any
    V: Any
    u: Any
    materials: dict[str, Material]
    traction: Any
    gravity_factor: Any
    terms: dict[str, Any]
    residual: Any
    jacobian: Any
    bcs: list[Any]
    energy: Any
    end_displacement: Any
    outer_z_dofs: np.ndarray
    pull_area: float
    dx: Any
    x: Any
    F: Any
    unknowns: Unknowns
    dynamics: Dynamics | None = None
    u_in_state: np.ndarray | None = None
    rigid_displacement: Any = None
    left_out: dict[str, str] = field(default_factory=dict)
    notes: dict[str, dict[str, Any]] = field(default_factory=dict)
    _compiled: dict[str, Any] = field(default_factory=dict, repr=False)

    def form(self, name: str) -> Any:
        """The compiled dolfinx form of attribute `name` (residual, jacobian, energy, ...), compiled once."""
        if name not in self._compiled:
            self._compiled[name] = dolfinx.fem.form(getattr(self, name))
        return self._compiled[name]

    def compiled(self) -> list[str]:
        """Names of the forms compiled so far."""
        return list(self._compiled)

    @property
    def mesh(self) -> Any:
        return self.tagged.mesh

    @property
    def comm(self) -> Any:
        return self.tagged.mesh.comm

    def traction_for(self, force_n: float) -> float:
        """Traction (Pa) whose 2 pi r-weighted integral over the pulled face is force_n."""
        return force_n / self.pull_area

    def set_force(self, force_n: float) -> None:
        self.traction.value = self.traction_for(force_n)

    def sync(self) -> None:
        """Copy the displacement part of the state into ``u`` (mixed formulation; no-op otherwise)."""
        if self.u_in_state is not None:
            self.u.x.array[:] = self.state.x.array[self.u_in_state]

    def num_dofs(self) -> int:
        """Size of the state's space (every mesh unknown, suture and pressure included)."""
        im = self.W.dofmap.index_map
        return int(im.size_global * self.W.dofmap.index_map_bs)

    def effects_record(self) -> dict[str, Any]:
        """The ``effects`` record of results.json: each effect on or off, why, and its numbers."""
        return self.effects.record(self.notes)

    def num_unknowns(self) -> int:
        """Number of unknowns SNES actually solves for."""
        return self.unknowns.count(self.comm)

    def region_tags(self, region: str) -> tuple[int, ...]:
        return tuple(t for t, r in REGION_OF_TAG.items() if r == region)


def build_physics(tagged: meshmod.TaggedMesh, scene: Scene) -> Physics:
    """Forms, boundary conditions and unknowns of a scene on a mesh, with only the called effects."""
    effects = Effects.from_scene(scene)
    mesh = tagged.mesh
    degree = scene.mesh.degree
    if effects.mixed:
        W = compat.mixed_space(mesh, degree, degree - 1)
        W_u = W.sub(0)
        V, u_in_state = W_u.collapse()
        u = dolfinx.fem.Function(V, name="displacement")
        state = dolfinx.fem.Function(W, name="state")
    else:
        W = V = W_u = compat.vector_space(mesh, degree)
        u = state = dolfinx.fem.Function(V, name="displacement")
        u_in_state = None
    test = ufl.TestFunction(W)
    x = ufl.SpatialCoordinate(mesh)
    weight = kinematics.volume_weight(x)
    q = quadrature_degree(degree)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=tagged.cell_tags, metadata={"quadrature_degree": q})
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged.facet_tags, metadata={"quadrature_degree": q})
    materials = {region: from_params(scene.materials.of(region)) for region in sorted(set(REGION_OF_TAG.values()))}
    present = _present_tags(tagged)
    region_tags = {}
    for region in ("hypodermis", "dermis", "epidermis", "suture"):
        tags = tuple(t for t, r in REGION_OF_TAG.items() if r == region and t in present)
        if tags:
            region_tags[region] = tags

    dynamics = Dynamics(W, scene) if effects.inertia else None
    w_eval = dynamics.evaluation_state(state) if dynamics is not None else state

    def displacement(w: Any) -> Any:
        return ufl.as_vector([w[0], w[1]]) if effects.mixed else w

    ctx = FormContext(
        w=state, u=displacement(w_eval), p=w_eval[2] if effects.mixed else None,
        v=displacement(test), q=test[2] if effects.mixed else None, test=test,
        x=x, weight=weight, dx=dx, ds=ds, materials=materials, region_tags=region_tags,
        scale=1.0 / (1.0 - dynamics.scheme.alpha_f) if dynamics is not None else 1.0,
    )
    terms = Terms()
    elastic_terms(ctx, effects, terms)
    traction = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    pull_term(ctx, traction, regions.Facet.PULL_FACE, terms)
    gravity_factor = None
    if effects.gravity:
        gravity_factor = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
        gravity_term(ctx, scene, gravity_factor, terms)
    if dynamics is not None:
        dynamics.terms(ctx, displacement, effects.rigid, terms)

    # with generalized-alpha the static terms sit at w_{n+1-alpha_f}: d/dw of Pi(w_eval) carries 1 - alpha_f
    residual = ctx.variation(sum(terms.potential.values()))
    for form in terms.residual.values():
        residual = residual + form
    jacobian = ufl.derivative(residual, state, ufl.TrialFunction(W))

    F = kinematics.deformation_gradient(u, x)
    energy = sum(materials[r].energy(F) * weight * dx(tags) for r, tags in region_tags.items()
                 if r != "suture" or not effects.rigid)

    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    outer = meshmod.facets(tagged, regions.Facet.OUTER)
    axis = meshmod.facets(tagged, regions.Facet.AXIS)
    zero = PETSc.ScalarType(0.0)
    bcs = [  # per component, so the same code serves the vector space and the mixed space's subspace
        dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(W_u.sub(c), fdim, outer), W_u.sub(c))
        for c in (0, 1)
    ]
    bcs.append(dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(W_u.sub(0), fdim, axis), W_u.sub(0)))
    left_out: dict[str, str] = {}
    notes: dict[str, dict[str, Any]] = {}
    if effects.mixed:
        # pressure unknowns that touch no tissue cell have no equation: pin them to 0
        tissue_cells = meshmod.region_cells(tagged, regions.TISSUE)
        in_tissue = mark_dofs(W, tissue_cells, W.sub(1))
        p_all = mark_dofs(W, np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32), W.sub(1))
        pinned = np.flatnonzero(p_all & ~in_tissue).astype(np.int32)
        bcs.append(dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), pinned, W.sub(1)))
        owned = W.dofmap.index_map.size_local
        notes["mixed"] = {
            "pressure_dofs": mesh.comm.allreduce(int(np.count_nonzero(p_all[:owned]))),
            "pressure_dofs_pinned_in_suture": mesh.comm.allreduce(int(np.count_nonzero(pinned < owned))),
        }
        left_out["suture pressure"] = "the suture keeps its displacement form; its pressure unknowns off the tissue are pinned to 0"
    outer_z = dolfinx.fem.locate_dofs_topological(W_u.sub(1), fdim, outer)
    rigid_displacement = rigid_bc = None
    if effects.rigid:
        # The constraint as boundary conditions (u_r = 0, u_z = d on every suture dof), so everything that
        # reads bcs sees which dofs are constrained; SNES imposes it through Reduction, which updates d.
        rigid_displacement = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
        suture_cells = meshmod.region_cells(tagged, regions.SUTURE)
        radial, axial = (np.flatnonzero(mark_dofs(W, suture_cells, W_u.sub(c))).astype(np.int32) for c in (0, 1))
        rigid_bc = dolfinx.fem.dirichletbc(rigid_displacement, axial, W_u.sub(1))
        bcs += [dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), radial, W_u.sub(0)), rigid_bc]
    unknowns = _unknowns(W, bcs, rigid_bc=rigid_bc)
    if effects.rigid:
        owned_kind = unknowns.kind[: unknowns.n_owned]
        notes["suture"] = {
            "suture_dofs_replaced": mesh.comm.allreduce(int(np.count_nonzero(owned_kind == RIGID))),
            "rigid_unknowns": 1,
        }
        left_out["suture elasticity"] = ("effects.suture = \"rigid\": the suture's strain energy is not built; "
                                         "its unknowns are replaced by one rigid axial motion")
    if dynamics is not None:
        e = scene.effects
        notes["inertia"] = {
            "time_scheme": e.time_scheme, "scheme": dynamics.scheme.__dict__, "time_step_s": e.time_step_s,
            "rayleigh_mass_per_s": e.rayleigh_mass_per_s, "rayleigh_stiffness_s": e.rayleigh_stiffness_s,
            "densities_kg_m3": dynamics.densities.by_region,
        }
    if effects.gravity:
        notes["gravity"] = {"g_m_s2": scene.effects.gravity_m_s2, "direction": scene.effects.gravity_direction,
                            "weight_n": weight_n(tagged, scene), "applied": "quasi-statically before the pull"}
    if not effects.inertia:
        left_out["inertia"] = "effects.inertia = false: no mass or damping form"
    if not effects.gravity:
        left_out["gravity"] = "effects.gravity = false: no body force"
    r_t = tagged.geometry.r_thread * regions.MM
    return Physics(
        tagged=tagged,
        degree=degree,
        effects=effects,
        W=W,
        state=state,
        V=V,
        u=u,
        materials=materials,
        traction=traction,
        gravity_factor=gravity_factor,
        terms={**terms.potential, **terms.residual},
        residual=residual,
        jacobian=jacobian,
        bcs=bcs,
        energy=energy,
        end_displacement=kinematics.axial(u) * weight * ds(regions.Facet.PULL_FACE),
        outer_z_dofs=np.asarray(outer_z, dtype=np.int32),
        pull_area=math.pi * r_t**2,
        dx=dx,
        x=x,
        F=F,
        unknowns=unknowns,
        dynamics=dynamics,
        u_in_state=u_in_state,
        rigid_displacement=rigid_displacement,
        left_out=left_out,
        notes=notes,
    )


def weight_n(tagged: meshmod.TaggedMesh, scene: Scene) -> float:
    """Total weight rho g V (N) from the mesh geometry, independently of the weak form.

    For a straight-sided triangle int r dA = A r_centroid exactly, so V = sum 2 pi A r_centroid.
    """
    mesh = tagged.mesh
    e = scene.effects
    n_owned = mesh.topology.index_map(2).size_local
    geom = mesh.geometry.x[:, :2]
    cells = mesh.geometry.dofmap.array.reshape(-1, 3)
    total = 0.0
    for tag, region in REGION_OF_TAG.items():
        ids = meshmod.region_cells(tagged, tag)
        ids = ids[ids < n_owned]
        p = geom[cells[ids]]
        area = 0.5 * np.abs(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]))
        total += e.density(region) * float(np.sum(2 * math.pi * area * p[:, :, 0].mean(axis=1)))
    return mesh.comm.allreduce(total) * e.gravity_m_s2


def _unknowns(W: Any, bcs: list[Any], rigid_bc: Any = None) -> Unknowns:
    """Classify every local dof of W: FIXED by a (zero) boundary condition, RIGID (u_z = d on the rigid
    suture's ``rigid_bc``) or FREE.
    """
    im = W.dofmap.index_map
    bs = W.dofmap.index_map_bs
    kind = np.full((im.size_local + im.num_ghosts) * bs, FREE, dtype=np.int8)
    for bc in bcs:
        kind[bc.dof_indices()[0]] = FIXED
    if rigid_bc is not None:
        kind[rigid_bc.dof_indices()[0]] = RIGID
    return Unknowns(kind=kind, n_owned=im.size_local * bs, rigid=rigid_bc is not None)


def _present_tags(tagged: meshmod.TaggedMesh) -> set[int]:
    """Cell tags present anywhere on the communicator (a region may be absent, e.g. no cones)."""
    local = set(int(t) for t in np.unique(tagged.cell_tags.values))
    return set().union(*tagged.mesh.comm.allgather(local))
