"""Physics: the discrete problem of a scene, assembled from the effects it calls for.

The quasi-static problem is the stationarity of Pi(u) = sum_regions int W_region(F(u)) 2 pi r dr dz -
int t . u 2 pi r ds_pull, t = F / (pi r_t^2) e_z on the thread's pulled end face (its 2 pi r-weighted
integral is the applied force F). The residual is the Gateaux derivative of Pi (plus the
non-potential terms of the called effects: the mixed formulation's pressure equation, inertia, damping;
friction's nodal terms are added by the solver) and the Jacobian its derivative again (UFL).
Outer epidermis surface: u = 0. Axis: u_r = 0. Else traction-free (:mod:`suture_fem.physics.constraints`).

Which terms exist is decided by :mod:`suture_fem.physics.effects`: an effect a scene leaves off is
never built (``Physics.terms`` names what was built; :meth:`Physics.effects_record` says what was not
and why).

Parameters. Every numeric material constant, ``materials.tissue_scale``, ``loading.force_scale`` and
the traction are dolfinx Constants (``Physics.parameters`` by scene key), so solving the same mesh at
another parameter value sets a Constant and compiles no new form (:meth:`Physics.set_parameter`), and
the residual's derivative with respect to a parameter is a form of its own
(:meth:`Physics.parameter_derivative`, for sensitivities by the direct method).

Unknowns. ``state`` is the unknown Function: the displacement, or (mixed) displacement and pressure.
``u`` is always the displacement alone (a view of ``state`` in the mixed case, kept in sync by
:meth:`Physics.sync`), so outputs and the domain guard never see the pressure. What SNES solves for is
``T x`` (:class:`~suture_fem.physics.constraints.Unknowns`): every dof that is not fixed by a boundary
condition, except that with a rigid suture all of the suture's dofs are replaced by one axial motion d.

:func:`build_physics` goes stage by stage: the spaces and the unknown, the measures and the form
context, the terms of each called effect, the boundary conditions and constraints, the notes of the
``effects`` record.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.regions import REGION_TAGS, REGIONS
from suture_fem.physics import kinematics
from suture_fem.physics.boundary import DisplacementControl, scene_constraints
from suture_fem.physics.constraints import Unknowns
from suture_fem.physics.effects import (
    Dynamics,
    Effects,
    elastic_terms,
    gravity_notes,
    gravity_term,
    strain_energy,
)
from suture_fem.physics.effects.cone_contact import ConeContact
from suture_fem.physics.effects.contact import contact_term, penalty_stiffness
from suture_fem.physics.effects.friction import ThreadFriction
from suture_fem.physics.forms import FormContext, Terms, face_area, measures, pull_term, restricted
from suture_fem.physics.materials import Material, with_constants
from suture_fem.scene.model import MaterialsSection, Scene
from suture_fem.scene.schema import EffectsSection
from suture_fem.support import compat


@dataclass
class Physics:
    """The discrete problem of a scene: unknowns, forms, boundary conditions, load parameters.

    Attributes:
        tagged: the mesh and its tags; degree: the displacement's polynomial degree.
        effects: what the scene calls for.
        W, state: space of the unknown and the unknown; V, u: displacement space and displacement.
        materials: region -> material.
        traction: the axial traction on the pulled face (Pa), set by the load stepping.
        gravity_factor: 0..1 multiplier of the weight (None without gravity).
        terms: residual contributions by effect (UFL forms); residual, jacobian: their sum and its derivative.
        tissue_residual: the residual over the tissue's cells (:mod:`suture_fem.outputs.interface`).
        contact_energy: the contact penalty's energy (UFL; None without it), for the line search's objective.
        friction: a Coulomb thread's nodal terms (:class:`ThreadFriction`; None without), added by the solver.
        cone_contact: the cones' contact terms (:class:`ConeContact`; None with tied cones), added by the solver.
        control: the pulled end's :class:`DisplacementControl` (``loading.control = "displacement"``; else None).
        bcs: Dirichlet conditions, in W (zero, except u_z = d on a rigid suture).
        energy: strain energy (J); end_displacement: 2 pi r-weighted integral of u_z over the pulled face.
        outer_z_dofs: the outer surface's u_z dofs (where the reaction force is read); pull_area: pi r_t^2 (3-D:
            the end face's area as meshed, doubled).
        dx, x, F: the cell measure, the coordinates and the deformation gradient of ``u``.
        unknowns: what SNES solves for; dynamics: time integration (None without inertia).
        u_in_state: where ``u``'s dofs sit in ``state`` (mixed; None otherwise).
        rigid_displacement: the rigid suture's axial motion d (a Constant; None with an elastic suture).
        notes: effect -> the numbers the ``effects`` record reports for it.
        parameters: scene key -> its dolfinx Constant (every material constant, ``materials.tissue_scale``,
            ``loading.force_scale``).
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
    tissue_residual: Any
    contact_energy: Any
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
    friction: ThreadFriction | None = None
    cone_contact: ConeContact | None = None
    control: DisplacementControl | None = None
    notes: dict[str, dict[str, Any]] = field(default_factory=dict)
    parameters: dict[str, Any] = field(default_factory=dict)
    _compiled: dict[str, Any] = field(default_factory=dict, repr=False)
    _derivatives: dict[str, Any] = field(default_factory=dict, repr=False)
    _kept: dict[str, Any] = field(default_factory=dict, repr=False)

    def form(self, name: str) -> Any:
        """The compiled dolfinx form of attribute `name` (residual, jacobian, energy, ...), compiled once."""
        if name not in self._compiled:
            self._compiled[name] = compat.form(getattr(self, name))
        return self._compiled[name]

    def compiled(self) -> list[str]:
        """Names of the forms compiled so far."""
        return list(self._compiled)

    def kept(self, name: str, build: Any) -> Any:
        """``build()``'s result, built once per physics (the Newton solver's guard and energy objective).

        Every solve of a :class:`~suture_fem.Model` would otherwise load them again.
        """
        if name not in self._kept:
            self._kept[name] = build()
        return self._kept[name]

    @property
    def mesh(self) -> Any:
        """The dolfinx mesh."""
        return self.tagged.mesh

    @property
    def comm(self) -> Any:
        """The mesh's communicator."""
        return self.tagged.mesh.comm

    def set_parameter(self, key: str, value: float) -> None:
        """Set a parameter's Constant (a key of ``parameters``): the next assembly uses the new value."""
        self.parameters[key].value = value

    def parameter_derivative(self, key: str) -> Any:
        """The compiled form of dR/dp for the parameter ``key`` (a vector form), compiled once.

        UFL 2022 cannot differentiate with respect to a Constant, so the Constant is replaced in the
        residual by a cellwise-constant Function holding the same value, and the residual is
        differentiated with respect to that Function in the direction of the unit function: the
        exact partial derivative. The Function's value follows the Constant's at each call.
        """
        if key not in self._derivatives:
            Q = compat.scalar_space(self.mesh, "DG", 0)
            value, one = dolfinx.fem.Function(Q), dolfinx.fem.Function(Q)
            one.x.array[:] = 1.0
            replaced = ufl.replace(self.residual, {self.parameters[key]: value})
            self._derivatives[key] = (dolfinx.fem.form(ufl.derivative(replaced, value, one)), value)
        form, value = self._derivatives[key]
        value.x.array[:] = float(self.parameters[key].value)
        return form

    def traction_for(self, force_n: float) -> float:
        """Traction (Pa) whose 2 pi r-weighted integral over the pulled face is force_n."""
        return force_n / self.pull_area

    @property
    def applied_traction(self) -> Any:
        """The traction the pull applies, as it enters the forms: ``traction * loading.force_scale`` (UFL)."""
        return self.traction * self.parameters["loading.force_scale"] if self.parameters else self.traction

    def applied_force_n(self) -> float:
        """The axial force the pull applies now (N): the nominal force times ``loading.force_scale``.

        Under displacement control: the force the pulled end takes (its reaction; collective).
        """
        if self.control is not None:
            return self.control.end_force(self)
        scale = float(self.parameters["loading.force_scale"].value) if self.parameters else 1.0
        return float(self.traction.value) * self.pull_area * scale

    def set_force(self, force_n: float) -> None:
        """Set the traction on the pulled face to that of the axial force force_n (N)."""
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
        """The cell tags of a material region (none for a name that is not one)."""
        return REGION_TAGS.get(region, ())


@dataclass
class _Spaces:
    """The unknown's space W and Function ``state``; the displacement's space V and Function ``u``.

    Without a pressure field they coincide (W = V = W_u, state = u); mixed, ``u`` is a copy of the
    state's displacement part W_u = W.sub(0), whose dofs in W are ``u_in_state``.
    """

    W: Any
    W_u: Any
    V: Any
    state: Any
    u: Any
    u_in_state: np.ndarray | None

    @classmethod
    def of(cls, mesh: Any, degree: int, mixed: bool) -> _Spaces:
        """Displacement (degree k), or Taylor-Hood displacement (k) and pressure (k - 1)."""
        if mixed:
            W = compat.mixed_space(mesh, degree, degree - 1)
            W_u = W.sub(0)
            V, u_in_state = W_u.collapse()
            u = dolfinx.fem.Function(V, name="displacement")
            return cls(W, W_u, V, dolfinx.fem.Function(W, name="state"), u, u_in_state)
        V = compat.vector_space(mesh, degree)
        u = dolfinx.fem.Function(V, name="displacement")
        return cls(V, V, V, u, u, None)


def build_physics(tagged: meshmod.TaggedMesh, scene: Scene) -> Physics:
    """Forms, boundary conditions and unknowns of a scene on a mesh, with only the called effects."""
    effects = Effects.from_scene(scene)
    degree = scene.mesh.degree
    spaces = _Spaces.of(tagged.mesh, degree, effects.mixed)
    dynamics = Dynamics(spaces.W, scene.effects) if effects.inertia else None
    ctx, parameters = _context(tagged, scene, spaces, degree, effects.mixed, dynamics)
    kappa = penalty_stiffness(scene, tagged.sizes.suture) if effects.unilateral_thread else None
    terms, traction, gravity_factor = _terms(ctx, effects, scene.effects, dynamics, parameters["loading.force_scale"],
                                             kappa)
    residual, jacobian = terms.residual_and_jacobian(ctx)
    constraints = scene_constraints(tagged, effects, spaces, scene.loading.control)
    u = spaces.u
    F = kinematics.deformation_gradient(u, ctx.x)
    r_t = tagged.geometry.r_thread * regions.MM
    physics = Physics(
        tagged=tagged,
        degree=degree,
        effects=effects,
        W=spaces.W,
        state=spaces.state,
        V=spaces.V,
        u=u,
        materials=ctx.materials,
        traction=traction,
        gravity_factor=gravity_factor,
        terms=terms.by_name(),
        residual=residual,
        jacobian=jacobian,
        tissue_residual=restricted(residual, regions.TISSUE),
        bcs=constraints.bcs,
        energy=strain_energy(ctx, F, effects.rigid),
        contact_energy=terms.potential.get("contact:thread"),
        end_displacement=kinematics.axial(u) * ctx.weight * ctx.ds(regions.Facet.PULL_FACE),
        outer_z_dofs=constraints.outer_z_dofs,
        pull_area=math.pi * r_t**2 if tagged.mesh.geometry.dim == 2 else face_area(ctx, regions.Facet.PULL_FACE),
        dx=ctx.dx,
        x=ctx.x,
        F=F,
        unknowns=constraints.unknowns,
        dynamics=dynamics,
        u_in_state=spaces.u_in_state,
        rigid_displacement=constraints.rigid_displacement,
        control=constraints.control,
        notes=_notes(tagged, effects, scene.effects, dynamics, constraints.notes, kappa),
        parameters=parameters,
    )
    if effects.frictional_thread:
        physics.friction = ThreadFriction.on(physics, scene.effects, kappa)
    if effects.cone_contact:
        physics.cone_contact = ConeContact.on(physics, scene)
    return physics


def _displacement_of(mixed: bool, dim: int = 2) -> Callable[[Any], Any]:
    """The displacement part ((u_r, u_z); in 3-D (u_x, u_y, u_z)) of an expression in the unknown's space."""
    if mixed:
        return lambda w: ufl.as_vector([w[i] for i in range(dim)])
    return lambda w: w


def _materials(mesh: Any, materials: MaterialsSection) -> tuple[dict[str, Material], dict[str, Any]]:
    """Every region's material on Constants, and the Constants by scene key (the tissue scale's among them)."""
    scale = dolfinx.fem.Constant(mesh, PETSc.ScalarType(materials.tissue_scale))
    parameters: dict[str, Any] = {"materials.tissue_scale": scale}
    out: dict[str, Material] = {}
    for region in sorted(REGIONS):
        tissue = region in regions.TISSUE_REGIONS
        out[region], consts = with_constants(materials.of(region), mesh, scale if tissue else 1.0)
        parameters.update({f"materials.{region}.{name}": c for name, c in consts.items()})
    return out, parameters


def _context(tagged: meshmod.TaggedMesh, scene: Scene, spaces: _Spaces, degree: int, mixed: bool,
             dynamics: Dynamics | None) -> tuple[FormContext, dict[str, Any]]:
    """The form context and the parameters' Constants by scene key.

    The context is what the effects write with: test functions, coordinates, measures, materials, the
    regions present.
    """
    mesh = tagged.mesh
    materials, parameters = _materials(mesh, scene.materials)
    parameters["loading.force_scale"] = dolfinx.fem.Constant(mesh, PETSc.ScalarType(scene.loading.force_scale))
    test = ufl.TestFunction(spaces.W)
    x = ufl.SpatialCoordinate(mesh)
    dx, ds = measures(mesh, tagged.cell_tags, tagged.facet_tags, degree)
    w_eval = dynamics.evaluation_state(spaces.state) if dynamics is not None else spaces.state
    dim = mesh.geometry.dim
    displacement = _displacement_of(mixed, dim)
    return FormContext(
        w=spaces.state, u=displacement(w_eval), p=w_eval[dim] if mixed else None,
        v=displacement(test), q=test[dim] if mixed else None, test=test,
        x=x, weight=kinematics.volume_weight(x), dx=dx, ds=ds,
        materials=materials,
        region_tags=meshmod.present_regions(tagged),
        scale=dynamics.scale if dynamics is not None else 1.0,
    ), parameters


def _terms(ctx: FormContext, effects: Effects, section: EffectsSection,
           dynamics: Dynamics | None, force_scale: Any, kappa: float | None) -> tuple[Terms, Any, Any]:
    """The terms of every called effect, and the load parameters: (terms, traction, gravity factor or None).

    The pull's traction is ``traction * force_scale``: the load stepping sets the nominal traction.
    """
    mesh = ctx.w.function_space.mesh
    terms = Terms()
    elastic_terms(ctx, effects, terms)
    if kappa is not None:  # a frictionless thread the tissue may leave: the penalty on its track
        contact_term(ctx, kappa, terms)
    traction = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    pull_term(ctx, traction * force_scale, regions.Facet.PULL_FACE, terms)
    gravity_factor = None
    if effects.gravity:
        gravity_factor = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
        gravity_term(ctx, section, gravity_factor, terms)
    if dynamics is not None:
        dynamics.terms(ctx, _displacement_of(effects.mixed, mesh.geometry.dim), effects.rigid, terms)
    return terms, traction, gravity_factor


def _notes(tagged: meshmod.TaggedMesh, effects: Effects, section: EffectsSection, dynamics: Dynamics | None,
           constraint_notes: dict[str, dict[str, Any]], kappa: float | None) -> dict[str, dict[str, Any]]:
    """The numbers of each called effect for the ``effects`` record (see :meth:`Effects.record`)."""
    notes = dict(constraint_notes)
    if kappa is not None:
        notes["interfaces"]["contact_penalty_pa_per_m"] = kappa
    if dynamics is not None:
        notes["inertia"] = dynamics.notes()
    if effects.gravity:
        notes["gravity"] = gravity_notes(tagged, section)
    return notes
