"""Inertia (``effects.inertia = true``): mass, Rayleigh damping and the time integration.

int rho a . v dV, with Rayleigh damping alpha_M int rho udot . v dV +
beta_K int (A(F_n) : dF[udot]) : dF[v] dV, where A = d2W/dF2 is the material tangent at the last
converged state and dF[w] the linearised deformation gradient. Time integration: Newmark (average
acceleration, gamma = 1/2, beta = 1/4) or generalized-alpha (Chung and Hulbert 1993) with spectral
radius rho_inf; the static terms are evaluated at u_{n+1-alpha_f}.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import dolfinx.fem
import ufl
from petsc4py import PETSc

from suture_fem.geometry.regions import REGIONS
from suture_fem.physics.effects.rigid import strained_regions
from suture_fem.physics.forms import FormContext, Terms
from suture_fem.scene.schema import EffectsSection


@dataclass(frozen=True)
class Densities:
    """Mass density of each region (kg/m^3)."""

    by_region: dict[str, float]

    @classmethod
    def from_section(cls, e: EffectsSection) -> Densities:
        """The densities of the scene's ``[effects]`` section."""
        return cls({r: e.density(r) for r in REGIONS})


@dataclass(frozen=True)
class Scheme:
    """Generalized-alpha parameters (Newmark average acceleration: alpha_m = alpha_f = 0)."""

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float

    @classmethod
    def from_section(cls, e: EffectsSection) -> Scheme:
        """The scheme of ``effects.time_scheme`` (and ``effects.spectral_radius`` for generalized-alpha)."""
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

    def __init__(self, W: Any, e: EffectsSection):
        self.section = e
        self.scheme = Scheme.from_section(e)
        self.w_n = dolfinx.fem.Function(W, name="w_n")
        self.v_n = dolfinx.fem.Function(W, name="v_n")
        self.a_n = dolfinx.fem.Function(W, name="a_n")
        self.dt = dolfinx.fem.Constant(W.mesh, PETSc.ScalarType(e.time_step_s))
        self.alpha_mass, self.beta_stiffness = e.rayleigh_mass_per_s, e.rayleigh_stiffness_s
        self.densities = Densities.from_section(e)

    def evaluation_state(self, w: Any) -> Any:
        """w_{n+1-alpha_f}: where the static terms are evaluated."""
        af = self.scheme.alpha_f
        return w if af == 0.0 else (1 - af) * w + af * self.w_n

    @property
    def scale(self) -> float:
        """1 / (1 - alpha_f): d/dw of a term evaluated at w_{n+1-alpha_f} carries 1 - alpha_f."""
        return 1.0 / (1.0 - self.scheme.alpha_f)

    def kinematics(self, w: Any) -> tuple[Any, Any]:
        """(acceleration, velocity) at n+1-alpha_m and n+1-alpha_f, as UFL expressions of the unknown w."""
        s, dt = self.scheme, self.dt
        a_new = (w - self.w_n - dt * self.v_n) / (s.beta * dt**2) - (1 / (2 * s.beta) - 1) * self.a_n
        v_new = self.v_n + dt * ((1 - s.gamma) * self.a_n + s.gamma * a_new)
        return (1 - s.alpha_m) * a_new + s.alpha_m * self.a_n, (1 - s.alpha_f) * v_new + s.alpha_f * self.v_n

    def terms(self, ctx: FormContext, displacement_of: Callable[[Any], Any], rigid: bool, terms: Terms) -> None:
        """Inertia and (when its coefficients are not zero) Rayleigh damping.

        Args:
            ctx: the form context (the unknown, test functions, measures, materials).
            displacement_of: the displacement part of a state-space expression (identity unless mixed).
            rigid: the suture is rigid (no strain rate, so no stiffness damping).
            terms: where the terms are written (``inertia``, ``damping:mass``, ``damping:stiffness``).
        """
        acc, vel = (displacement_of(e) for e in self.kinematics(ctx.w))
        rho = self.densities.by_region
        regions = list(ctx.region_tags)
        terms.residual["inertia"] = sum(rho[r] * ufl.dot(acc, ctx.v) * ctx.weight * ctx.over(r) for r in regions)
        if self.alpha_mass > 0:
            terms.residual["damping:mass"] = self.alpha_mass * sum(
                rho[r] * ufl.dot(vel, ctx.v) * ctx.weight * ctx.over(r) for r in regions)
        if self.beta_stiffness > 0:
            terms.residual["damping:stiffness"] = self.beta_stiffness * self._stiffness_damping(
                ctx, displacement_of, vel, rigid)

    def _stiffness_damping(self, ctx: FormContext, displacement_of: Callable[[Any], Any], vel: Any,
                           rigid: bool) -> Any:
        """sum_regions int (A(F_n) : dF[udot]) : dF[v] dV over the regions that deform."""
        F_n = ctx.F(displacement_of(self.w_n))
        dF_vel = ctx.F(vel) - ufl.Identity(3)
        # dF[v]: F is affine in u, so its Gateaux derivative in the direction of the test function
        dF_test = ufl.derivative(ctx.F(displacement_of(ctx.w)), ctx.w, ctx.test)
        form = 0
        for r in strained_regions(ctx.region_tags, rigid):  # a rigid translation has no strain rate
            Fv = ufl.variable(F_n)
            P = ufl.diff(ctx.materials[r].energy(Fv), Fv)
            A = ufl.diff(P, Fv)
            i, j, k, m = ufl.indices(4)
            damping_stress = ufl.as_tensor(A[i, j, k, m] * dF_vel[k, m], (i, j))
            form += ufl.inner(damping_stress, dF_test) * ctx.weight * ctx.over(r)
        return form

    def notes(self) -> dict[str, Any]:
        """The ``inertia`` numbers of the effects record: scheme, time step, damping, densities."""
        e = self.section
        return {
            "time_scheme": e.time_scheme, "scheme": asdict(self.scheme), "time_step_s": e.time_step_s,
            "rayleigh_mass_per_s": e.rayleigh_mass_per_s, "rayleigh_stiffness_s": e.rayleigh_stiffness_s,
            "densities_kg_m3": self.densities.by_region,
        }

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
