"""What an effect needs to write its terms: the form context, the named terms, the quadrature degree.

Every effect (:mod:`suture_fem.physics.effects`) writes its contribution to the residual as named
UFL terms into a :class:`Terms`, from the unknown, test functions, coordinates, measures and
materials gathered in a :class:`FormContext`. The pull on the thread's end face is the one load every
scene has, so its term lives here too.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import dolfinx.fem
import ufl

from suture_fem.physics import kinematics
from suture_fem.support import compat


def quadrature_degree(degree: int) -> int:
    """Quadrature degree for the (non-polynomial) hyperelastic integrands of a degree-k field."""
    return 2 * degree


def measures(mesh: Any, cell_tags: Any, facet_tags: Any, degree: int) -> tuple[Any, Any]:
    """(dx, ds): cell and facet measures with the mesh's tags and the quadrature degree of a degree-k field."""
    q = quadrature_degree(degree)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags, metadata={"quadrature_degree": q})
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags, metadata={"quadrature_degree": q})
    return dx, ds


@dataclass
class FormContext:
    """What an effect needs to write its terms.

    Attributes:
        w: the unknown Function (displacement, or displacement and pressure).
        u, p: displacement and pressure of the state at which the static terms are evaluated
            (u_{n+1-alpha_f} with generalized-alpha, else the unknown itself); p is None unless mixed.
        v, q: the test functions of u and p (q None unless mixed); test: the test function of w.
        x, weight: coordinates and 2 pi r; dx, ds: measures with the cell and facet tags.
        materials: region -> material.
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
        d = ufl.derivative(expr, self.w, self.test)
        return d if self.scale == 1.0 else self.scale * d

    def F(self, u: Any) -> Any:
        """Deformation gradient (3x3, axisymmetric) of a displacement."""
        return kinematics.deformation_gradient(u, self.x)

    def over(self, region: str) -> Any:
        """The cell measure restricted to a region's tags."""
        return self.dx(self.region_tags[region])


@dataclass
class Terms:
    """The residual, by effect. ``potential`` terms are differentiated; ``residual`` terms are added as is."""

    potential: dict[str, Any] = field(default_factory=dict)
    residual: dict[str, Any] = field(default_factory=dict)

    def by_name(self) -> dict[str, Any]:
        """Every term (UFL form) by name, potential ones first."""
        return {**self.potential, **self.residual}

    def residual_and_jacobian(self, ctx: FormContext) -> tuple[Any, Any]:
        """The residual (variation of the potential terms plus the residual terms) and its exact derivative.

        With generalized-alpha the static terms sit at w_{n+1-alpha_f}: ``ctx.variation`` undoes the
        1 - alpha_f that d/dw of Pi(w_eval) carries.
        """
        residual = ctx.variation(sum(self.potential.values()))
        for form in self.residual.values():
            residual = residual + form
        return residual, ufl.derivative(residual, ctx.w, ufl.TrialFunction(ctx.w.function_space))


def pull_term(ctx: FormContext, traction: Any, face_tag: int, terms: Terms) -> None:
    """The pull: - int t u_z ds on the thread's end face (t a Constant, F / (pi r_t^2))."""
    terms.potential["pull"] = -traction * kinematics.axial(ctx.u) * ctx.weight * ctx.ds(face_tag)


def restricted(form: Any, tags: tuple[int, ...]) -> Any:
    """The cell integrals of a form over the given cell tags only (every term is written per region).

    Applied to the residual with the tissue's tags it is the tissue's part of the residual: at an
    interface node, the force the suture applies to the tissue.
    """
    wanted = set(int(t) for t in tags)
    kept = []
    for integral in form.integrals():
        ids = integral.subdomain_id()
        ids = set(int(i) for i in (ids if isinstance(ids, tuple) else (ids,))) if ids != "everywhere" else None
        if integral.integral_type() == "cell" and ids is not None and ids <= wanted:
            kept.append(integral)
    return ufl.Form(kept)


def face_area(ctx: FormContext, tag: int) -> float:
    """The weighted area of a tagged face as meshed (m^2): in 3-D the polygonal end face is smaller than pi r_t^2."""
    from mpi4py import MPI

    local = dolfinx.fem.assemble_scalar(compat.form(ctx.weight * ctx.ds(tag)))
    return float(ctx.w.function_space.mesh.comm.allreduce(local, op=MPI.SUM))
