"""Effects: the parts of the weak form a scene calls for, each built only when called.

A scene's ``[effects]`` section names the physics it needs, and ``output.quantities`` the outputs:

| key | values | what is built |
| --- | --- | --- |
| ``effects.incompressibility`` | ``"displacement"`` / ``"mixed"`` | tissue volumetric response from u alone, or through a pressure field (Taylor-Hood P2/P1) |
| ``effects.suture`` | ``"elastic"`` / ``"rigid"`` | the suture's St Venant-Kirchhoff energy, or no suture energy and one rigid axial motion instead of the suture's unknowns |
| ``effects.inertia`` | true / false | mass (and Rayleigh damping) terms and time integration over ramp and hold |
| ``effects.gravity`` | true / false | the tissue's and suture's weight as an axial body force |

Each effect contributes named terms to the residual (:class:`Terms`); what a scene leaves off is
never built, so no form of it is compiled or assembled, and :meth:`Effects.record` says what was
left out and why (it goes into ``results.json`` as ``effects``).

The weak forms, with dV = 2 pi r dr dz (:mod:`suture_fem.kinematics`), u the displacement, v its
test function:

* Elasticity, plain displacement: delta Pi[v] with Pi = sum_regions int W(F(u)) dV.
* Elasticity, mixed: in each tissue region the stress U'(J) cof F of the volumetric energy is replaced
  by p cof F (the residual int W_iso'(F) : dF[v] + p dJ[v] dV, with p held fixed in the variation),
  and the pressure p (continuous P1) solves int (U'(J) - p) / K0 q dV = 0 for every test q, i.e.
  p is the P1 projection of the constitutive pressure U'(J) (K0 = initial bulk modulus; for 1/d = 0
  the equation is int (J - 1) q dV = 0, exact incompressibility). The material law is unchanged;
  only its volumetric part is approximated one polynomial degree lower, which removes the locking
  of the plain formulation as K0 / mu grows. The suture keeps its displacement form; its pressure
  unknowns that touch no tissue cell are pinned to 0 (Dirichlet), so the pressure lives on the
  tissue only (see physics.py).
* Pull: - int t u_z ds on the thread's end face, t = F / (pi r_t^2).
* Gravity: - int rho g s u_z dV, s = -1 for ``"-z"`` (opposite to the pull), +1 for ``"+z"``; only an
  axial direction is axisymmetric.
* Inertia: int rho a . v dV, with Rayleigh damping alpha_M int rho udot . v dV +
  beta_K int (A(F_n) : dF[udot]) : dF[v] dV, where A = d2W/dF2 is the material tangent at the last
  converged state and dF[w] the linearised deformation gradient. Time integration: Newmark
  (average acceleration, gamma = 1/2, beta = 1/4) or generalized-alpha (Chung and Hulbert 1993) with
  spectral radius rho_inf; the static terms are evaluated at u_{n+1-alpha_f}.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

from suture_fem.scene.model import Scene
from suture_fem.support.errors import SceneError

# ufl, dolfinx and petsc4py are imported where the forms are built, so scene validation
# (check_scene) stays free of them.

log = logging.getLogger("suture_fem")

QUANTITIES = ("usum", "seqv", "eptoeqv")
HOLD_SKIPPED = (
    "hold skipped: no rate-dependent effect in the scene (inertia off, every material rate-independent), "
    "so the state at the end of the hold equals the state at the peak force"
)


@dataclass(frozen=True)
class Effects:
    """What a scene calls for (validated ``[effects]`` and ``output.quantities``)."""

    inertia: bool = False
    suture: str = "elastic"
    incompressibility: str = "displacement"
    gravity: bool = False
    quantities: tuple[str, ...] = QUANTITIES
    hold_s: float = 0.0

    @classmethod
    def from_scene(cls, scene: Scene) -> Effects:
        e = scene.effects
        return cls(
            inertia=e.inertia,
            suture=e.suture,
            incompressibility=e.incompressibility,
            gravity=e.gravity,
            quantities=tuple(q for q in QUANTITIES if q in scene.output.quantities),
            hold_s=scene.loading.hold_s,
        )

    @property
    def rigid(self) -> bool:
        return self.suture == "rigid"

    @property
    def mixed(self) -> bool:
        return self.incompressibility == "mixed"

    def record(self, notes: dict[str, Any] | None = None) -> dict[str, Any]:
        """Each effect on or off, and for each one off or skipped the reason (JSON-ready)."""
        notes = notes or {}
        rec: dict[str, Any] = {}
        if self.inertia:
            rec["inertia"] = {"on": True, **notes.get("inertia", {})}
        else:
            rec["inertia"] = {"on": False, "left_out": "effects.inertia = false: quasi-static load ramp; no mass or "
                              "damping form is built, compiled or assembled"}
        if self.rigid:
            rec["suture"] = {"on": True, "treatment": "rigid", "left_out": "effects.suture = \"rigid\": no suture "
                             "strain energy; the suture's unknowns are replaced by one rigid axial motion",
                             **notes.get("suture", {})}
        else:
            rec["suture"] = {"on": True, "treatment": "elastic", **notes.get("suture", {})}
        if self.mixed:
            rec["incompressibility"] = {"on": True, "treatment": "mixed", "formulation":
                                        "Taylor-Hood P2 displacement / P1 pressure in the tissue", **notes.get("mixed", {})}
        else:
            rec["incompressibility"] = {"on": True, "treatment": "displacement",
                                        "left_out": "effects.incompressibility = \"displacement\": no pressure field"}
        rec["gravity"] = {"on": True, **notes.get("gravity", {})} if self.gravity else {
            "on": False, "left_out": "effects.gravity = false: no body force"}
        if self.inertia and self.hold_s > 0:
            rec["hold"] = {"solved": True, "reason": "inertia on: the hold is integrated in time"}
        elif self.hold_s > 0:
            rec["hold"] = {"solved": False, "left_out": HOLD_SKIPPED}
        else:
            rec["hold"] = {"solved": False, "left_out": "loading.hold_s = 0: no hold"}
        left = [q for q in QUANTITIES if q not in self.quantities]
        rec["outputs"] = {"computed": list(self.quantities),
                          "left_out": {q: "not in output.quantities: never computed" for q in left}}
        if not {"seqv", "eptoeqv"} & set(self.quantities):
            rec["outputs"]["stress_strain_fields"] = "not compiled: neither seqv nor eptoeqv is requested"
        return rec


def check_scene(scene: Scene) -> None:
    """Cross-key rules of the effects (run by scene validation, before any meshing)."""
    e = scene.effects
    if e.incompressibility == "mixed" and scene.mesh.degree < 2:
        raise SceneError(
            'scene key effects.incompressibility = "mixed" needs mesh.degree = 2 (Taylor-Hood P2/P1 is the stable '
            "pair; P1/P0 and P1/P1 are not), got mesh.degree = 1"
        )
    if e.inertia and e.time_step_s > scene.loading.ramp_s + scene.loading.hold_s:
        raise SceneError(
            f"scene key effects.time_step_s = {e.time_step_s:g} must be <= loading.ramp_s + loading.hold_s"
        )
    quantities = scene.output.quantities
    if not quantities:
        raise SceneError("scene key output.quantities must name at least one of " + ", ".join(QUANTITIES))


@dataclass
class FormContext:
    """What an effect needs to write its terms.

    Attributes:
        w: the unknown Function (displacement, or displacement and pressure).
        u, p: displacement and pressure of the state at which the static terms are evaluated
            (u_{n+1-alpha_f} with generalized-alpha, else the unknown itself); p is None unless mixed.
        v, q: the test functions of u and p (q None unless mixed); test: the test function of w.
        x, weight: coordinates and 2 pi r; dx, ds: measures with the cell and facet tags.
        region_tags: region -> cell tags present in the mesh.
        scale: 1 / (1 - alpha_f): undoes the factor the evaluation state w_{n+1-alpha_f} puts on d/dw.
    """

    w: Any
    u: Any
    p: Any
    v: Any
    q: Any
    test: Any
    x: Any
    weight: Any
    dx: Any
    ds: Any
    materials: dict[str, Any]
    region_tags: dict[str, tuple[int, ...]]
    scale: float = 1.0

    def variation(self, expr: Any) -> Any:
        """d(expr)[test]: the Gateaux derivative of an expression of the evaluation state."""
        import ufl

        d = ufl.derivative(expr, self.w, self.test)
        return d if self.scale == 1.0 else self.scale * d

    def F(self, u: Any) -> Any:
        from suture_fem.physics import kinematics

        return kinematics.deformation_gradient(u, self.x)

    def over(self, region: str) -> Any:
        return self.dx(self.region_tags[region])


@dataclass
class Terms:
    """The residual, by effect. ``potential`` terms are differentiated; ``residual`` terms are added as is."""

    potential: dict[str, Any] = field(default_factory=dict)
    residual: dict[str, Any] = field(default_factory=dict)

    def names(self) -> list[str]:
        return [*self.potential, *self.residual]


TISSUE = ("hypodermis", "dermis", "epidermis")


def elastic_terms(ctx: FormContext, effects: Effects, terms: Terms) -> None:
    """Strain energy of every region the scene deforms, by the called incompressibility treatment."""
    import ufl

    F = ctx.F(ctx.u)
    for region in TISSUE:
        if region not in ctx.region_tags:
            continue
        mat = ctx.materials[region]
        if effects.mixed:
            J = ufl.det(F)
            terms.potential[f"elastic:{region}"] = mat.isochoric(F) * ctx.weight * ctx.over(region)
            # p dJ[v] only (not a p-variation of p (J - 1), which would add int (J - 1) q to the pressure row)
            terms.residual[f"pressure:{region}"] = (
                ctx.p * ctx.variation(J) + _pressure_equation(mat, J, ctx.p) * ctx.q
            ) * ctx.weight * ctx.over(region)
        else:
            terms.potential[f"elastic:{region}"] = mat.energy(F) * ctx.weight * ctx.over(region)
    if "suture" in ctx.region_tags and not effects.rigid:
        terms.potential["elastic:suture"] = ctx.materials["suture"].energy(F) * ctx.weight * ctx.over("suture")


def _pressure_equation(mat: Any, J: Any, p: Any) -> Any:
    """(U'(J) - p) / K0, or J - 1 for an incompressible material (1/d = 0)."""
    import ufl

    K0 = mat.bulk_modulus
    if K0 == 0.0:
        return J - 1
    Jv = ufl.variable(J)
    return (ufl.diff(mat.volumetric(Jv), Jv) - p) / K0


def pull_term(ctx: FormContext, traction: Any, face_tag: int, terms: Terms) -> None:
    from suture_fem.physics import kinematics

    terms.potential["pull"] = -traction * kinematics.axial(ctx.u) * ctx.weight * ctx.ds(face_tag)


@dataclass(frozen=True)
class Densities:
    """Mass density of each region (kg/m^3)."""

    by_region: dict[str, float]

    @classmethod
    def from_scene(cls, scene: Scene) -> Densities:
        e = scene.effects
        return cls({r: e.density(r) for r in (*TISSUE, "suture")})


def gravity_term(ctx: FormContext, scene: Scene, factor: Any, terms: Terms) -> None:
    """Weight of every region as an axial body force, scaled by ``factor`` (0 -> 1 in the preload)."""
    from suture_fem.physics import kinematics

    e = scene.effects
    g = e.gravity_m_s2 * (1.0 if e.gravity_direction == "+z" else -1.0)
    rho = Densities.from_scene(scene).by_region
    work = sum(rho[r] * g * kinematics.axial(ctx.u) * ctx.weight * ctx.over(r) for r in ctx.region_tags)
    terms.potential["gravity"] = -factor * work


@dataclass(frozen=True)
class Scheme:
    """Generalized-alpha parameters (Newmark average acceleration: alpha_m = alpha_f = 0)."""

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @classmethod
    def from_scene(cls, scene: Scene) -> Scheme:
        e = scene.effects
        if e.time_scheme == "newmark":
            return cls(0.0, 0.0, 0.5, 0.25)
        rho = e.spectral_radius  # Chung & Hulbert (1993), eq. 25
        am, af = (2 * rho - 1) / (rho + 1), rho / (rho + 1)
        gamma = 0.5 - am + af
        return cls(am, af, gamma, 0.25 * (1 - am + af) ** 2)


class Dynamics:
    """State history and time step of the time integration; its terms are the inertia effect.

    Holds w_n, v_n, a_n (Functions in the unknown's space) and dt (a Constant set per step).
    """

    def __init__(self, W: Any, scene: Scene):
        import dolfinx.fem
        from petsc4py import PETSc

        self.scheme = Scheme.from_scene(scene)
        mesh = W.mesh
        self.w_n = dolfinx.fem.Function(W, name="w_n")
        self.v_n = dolfinx.fem.Function(W, name="v_n")
        self.a_n = dolfinx.fem.Function(W, name="a_n")
        self.dt = dolfinx.fem.Constant(mesh, PETSc.ScalarType(scene.effects.time_step_s))
        e = scene.effects
        self.alpha_mass, self.beta_stiffness = e.rayleigh_mass_per_s, e.rayleigh_stiffness_s
        self.densities = Densities.from_scene(scene)

    def evaluation_state(self, w: Any) -> Any:
        """w_{n+1-alpha_f}: where the static terms are evaluated."""
        af = self.scheme.alpha_f
        return w if af == 0.0 else (1 - af) * w + af * self.w_n

    def kinematics(self, w: Any) -> tuple[Any, Any]:
        """(acceleration, velocity) at n+1-alpha_m and n+1-alpha_f, as UFL expressions of the unknown w."""
        s, dt = self.scheme, self.dt
        a_new = (w - self.w_n - dt * self.v_n) / (s.beta * dt**2) - (1 / (2 * s.beta) - 1) * self.a_n
        v_new = self.v_n + dt * ((1 - s.gamma) * self.a_n + s.gamma * a_new)
        return (1 - s.alpha_m) * a_new + s.alpha_m * self.a_n, (1 - s.alpha_f) * v_new + s.alpha_f * self.v_n

    def terms(self, ctx: FormContext, displacement_of: Any, rigid: bool, terms: Terms) -> None:
        """Inertia and (when its coefficients are not zero) Rayleigh damping."""
        import ufl

        acc, vel = (displacement_of(e) for e in self.kinematics(ctx.w))
        rho = self.densities.by_region
        regions = list(ctx.region_tags)
        terms.residual["inertia"] = sum(rho[r] * ufl.dot(acc, ctx.v) * ctx.weight * ctx.over(r) for r in regions)
        if self.alpha_mass > 0:
            terms.residual["damping:mass"] = self.alpha_mass * sum(
                rho[r] * ufl.dot(vel, ctx.v) * ctx.weight * ctx.over(r) for r in regions)
        if self.beta_stiffness > 0:
            F_n = ctx.F(displacement_of(self.w_n))
            dF_vel = ctx.F(vel) - ufl.Identity(3)
            # dF[v]: F is affine in u, so its Gateaux derivative in the direction of the test function
            dF_test = ufl.derivative(ctx.F(displacement_of(ctx.w)), ctx.w, ctx.test)
            form = 0
            for r in regions:
                if r == "suture" and rigid:
                    continue  # a rigid translation has no strain rate
                Fv = ufl.variable(F_n)
                P = ufl.diff(ctx.materials[r].energy(Fv), Fv)
                A = ufl.diff(P, Fv)
                i, j, k, l = ufl.indices(4)
                damping_stress = ufl.as_tensor(A[i, j, k, l] * dF_vel[k, l], (i, j))
                form += ufl.inner(damping_stress, dF_test) * ctx.weight * ctx.over(r)
            terms.residual["damping:stiffness"] = self.beta_stiffness * form

    def accept(self, w: Any) -> None:
        """After a converged step: a_{n+1}, v_{n+1}, w_{n+1} become the history (array arithmetic, ghosts included)."""
        s, dt = self.scheme, float(self.dt.value)
        wa, wn, vn, an = w.x.array, self.w_n.x.array, self.v_n.x.array, self.a_n.x.array
        a_new = (wa - wn - dt * vn) / (s.beta * dt**2) - (1 / (2 * s.beta) - 1) * an
        vn += dt * ((1 - s.gamma) * an + s.gamma * a_new)
        an[:] = a_new
        wn[:] = wa

    def start_from(self, w: Any) -> None:
        """Rest at the state w (e.g. after the gravity preload): v = a = 0."""
        self.w_n.x.array[:] = w.x.array
        self.v_n.x.array[:] = 0.0
        self.a_n.x.array[:] = 0.0


def mark_dofs(W: Any, cells: Any, sub: Any | None = None) -> Any:
    """Boolean mask over W's local dofs (owned and ghost): touched by any of the cells on any rank.

    ``sub`` restricts to a subspace of W (its dofmap indexes W). The marks are summed onto the owners
    and sent back to the ghosts, so a dof shared across ranks is marked everywhere.
    """
    import dolfinx.fem
    import numpy as np

    from suture_fem.support import compat

    space = W if sub is None else sub
    carrier = dolfinx.fem.Function(W)
    carrier.x.array[:] = 0.0
    if len(cells):
        dofs = space.dofmap.list.array.reshape(-1, space.dofmap.dof_layout.num_dofs)[cells]
        bs = space.dofmap.bs
        if bs > 1:  # a blocked dofmap lists nodes: unroll
            dofs = (bs * dofs[:, :, None] + np.arange(bs)[None, None, :]).reshape(len(cells), -1)
        carrier.x.array[np.unique(dofs)] = 1.0
    compat.scatter_reverse_add(carrier.x)
    carrier.x.scatter_forward()
    return carrier.x.array > 0.5
