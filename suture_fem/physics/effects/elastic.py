"""Elasticity: the strain energy of every region the scene deforms.

Plain displacement formulation: delta Pi[v] with Pi = sum_regions int W(F(u)) dV, dV = 2 pi r dr dz
(:mod:`suture_fem.physics.kinematics`). With ``effects.incompressibility = "mixed"`` the tissue's
volumetric response goes through a pressure field instead (:mod:`.mixed`); a rigid suture has no
strain energy (:mod:`.rigid`).
"""

from __future__ import annotations

from typing import Any

from suture_fem.geometry.regions import TISSUE_REGIONS
from suture_fem.physics.effects.mixed import mixed_tissue_terms
from suture_fem.physics.effects.record import Effects
from suture_fem.physics.effects.rigid import strained_regions
from suture_fem.physics.forms import FormContext, Terms


def elastic_terms(ctx: FormContext, effects: Effects, terms: Terms) -> None:
    """Strain energy of every region the scene deforms, by the called incompressibility treatment."""
    F = ctx.F(ctx.u)
    for region in strained_regions(ctx.region_tags, effects.rigid):
        if effects.mixed and region in TISSUE_REGIONS:
            mixed_tissue_terms(ctx, region, F, terms)
        else:
            terms.potential[f"elastic:{region}"] = ctx.materials[region].energy(F) * ctx.weight * ctx.over(region)


def strain_energy(ctx: FormContext, F: Any, rigid: bool) -> Any:
    """The strain energy (J) of the regions that deform, at the deformation gradient F (a UFL form)."""
    return sum(ctx.materials[r].energy(F) * ctx.weight * ctx.over(r) for r in strained_regions(ctx.region_tags, rigid))
