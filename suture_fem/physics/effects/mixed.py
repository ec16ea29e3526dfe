"""The mixed displacement-pressure formulation of the tissue (``effects.incompressibility = "mixed"``).

In each tissue region the stress U'(J) cof F of the volumetric energy is replaced by p cof F (the
residual int W_iso'(F) : dF[v] + p dJ[v] dV, with p held fixed in the variation), and the pressure p
(continuous P1) solves int (U'(J) - p) / K0 q dV = 0 for every test q, i.e. p is the P1 projection of
the constitutive pressure U'(J) (K0 = initial bulk modulus; for 1/d = 0 the equation is
int (J - 1) q dV = 0, exact incompressibility). The material law is unchanged; only its volumetric
part is approximated one polynomial degree lower (Taylor-Hood P2/P1), which removes the locking of
the plain formulation as K0 / mu grows. The suture keeps its displacement form; its pressure unknowns
that touch no tissue cell are pinned to 0 (:func:`suture_fem.physics.constraints.pinned_pressure`),
so the pressure lives on the tissue only.
"""

from __future__ import annotations

from typing import Any

import ufl

from suture_fem.physics.forms import FormContext, Terms


def mixed_tissue_terms(ctx: FormContext, region: str, F: Any, terms: Terms) -> None:
    """A tissue region's isochoric energy (potential) and its pressure terms (residual as is)."""
    mat = ctx.materials[region]
    J = ufl.det(F)
    terms.potential[f"elastic:{region}"] = mat.isochoric(F) * ctx.weight * ctx.over(region)
    # p dJ[v] only (not a p-variation of p (J - 1), which would add int (J - 1) q to the pressure row)
    terms.residual[f"pressure:{region}"] = (
        ctx.p * ctx.variation(J) + pressure_equation(mat, J, ctx.p) * ctx.q
    ) * ctx.weight * ctx.over(region)


def pressure_equation(mat: Any, J: Any, p: Any) -> Any:
    """(U'(J) - p) / K0, or J - 1 for an incompressible material (1/d = 0)."""
    if mat.bulk_modulus == 0.0:
        return J - 1
    Jv = ufl.variable(J)
    return (ufl.diff(mat.volumetric(Jv), Jv) - p) / mat.bulk_modulus_form()
