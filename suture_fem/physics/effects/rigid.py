"""The rigid suture (``effects.suture = "rigid"``): what it changes in the problem.

A rigid suture has no strain energy and no strain rate: it is left out of the elastic terms, the
strain energy and the stiffness-proportional damping (:func:`strained_regions`). Its unknowns are
replaced by one axial motion d, u = (0, d) on every suture node, the interface included; that
constraint is written as boundary conditions (:func:`suture_fem.physics.constraints.rigid_suture`),
which make the suture's axial dofs RIGID, and d's equation is the axial force balance of the suture.
The suture's mass still counts (inertia, gravity): a rigid body moving by d.
"""

from __future__ import annotations

from typing import Any

from suture_fem.geometry.regions import REGIONS, SUTURE_REGION
from suture_fem.physics.constraints import Unknowns


def strained_regions(region_tags: dict[str, tuple[int, ...]], rigid: bool) -> list[str]:
    """The regions present that deform: every one, except the suture when it is rigid.

    In the order of :data:`~suture_fem.geometry.regions.REGIONS` (tissue inside out, then the suture),
    so the terms are summed in the same order whatever order ``region_tags`` lists them in.
    """
    return [r for r in REGIONS if r in region_tags and (r != SUTURE_REGION or not rigid)]


def rigid_notes(unknowns: Unknowns, comm: Any) -> dict[str, int]:
    """The ``suture`` numbers of the effects record: dofs replaced by d, and the one unknown d."""
    return {"suture_dofs_replaced": unknowns.count_rigid(comm), "rigid_unknowns": 1}
