"""SEQV and EPTOEQV at the rounded cone rims: the maximum over the tissue within one fillet radius of a fillet arc.

With ``geometry.cone_fillet_mm`` > 0 the base rims are circular arcs, meshed with at least
``mesh.fillet_elements`` elements along each (doubled per refinement, :mod:`suture_fem.geometry.gmsh_model`).
The stress there is bounded and resolved, so this peak is a well-defined quantity that converges under
refinement, unlike the raw maximum, which may sit at a remaining sharp corner (the apex rims). The zone is
every quadrature point of the tissue at most two fillet radii from an arc's centre. Absent without a fillet.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suture_fem.geometry.outline import meridian
from suture_fem.geometry.regions import MM, TISSUE_REGIONS
from suture_fem.outputs.base import Quantity, Setup, State, global_max
from suture_fem.outputs.eptoeqv import Eptoeqv
from suture_fem.outputs.seqv import Seqv
from suture_fem.scene.schema import OutputSection

#: The zone around an arc: points closer to its centre than this many fillet radii.
ZONE_RADII = 2.0


class FilletPeak(Quantity):
    """``seqv_fillet_pa`` and ``eptoeqv_fillet`` of each tissue layer that touches a fillet, with their points."""

    @classmethod
    def wanted(cls, quantities: tuple[str, ...]) -> bool:
        """Asked for with SEQV or EPTOEQV."""
        return Seqv.option in quantities or Eptoeqv.option in quantities

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where the maxima are taken."""
        zone = (f"maximum over the tissue's quadrature points within {ZONE_RADII:g} fillet radii of a fillet arc's "
                "centre (the rounded base rims, geometry.cone_fillet_mm > 0, resolved by mesh.fillet_elements); "
                "converges under refinement")
        return {"seqv_fillet_pa": "von Mises stress " + zone, "eptoeqv_fillet": "equivalent Hencky strain " + zone}

    def __init__(self, setup: Setup):
        super().__init__(setup)
        self.zone: dict[str, np.ndarray] = {}
        points = setup.points
        if points is None:
            return
        geometry = setup.physics.tagged.geometry
        arcs = [(seg[1], np.hypot(seg[0][0] - seg[1][0], seg[0][1] - seg[1][1]))
                for cone in geometry.cones for kind, seg in cone.outline if kind == "arc"]
        for region in TISSUE_REGIONS:
            xy = meridian(points.xy[region]) / MM  # (r, z); in 3-D (sqrt(x^2 + z^2), y)
            near = np.zeros(len(xy), dtype=bool)
            for (rc, zc), radius in arcs:
                near |= np.hypot(xy[:, 0] - rc, xy[:, 1] - zc) <= ZONE_RADII * radius
            if setup.physics.comm.allreduce(int(near.sum())) > 0:  # collective: every rank builds every quantity
                self.zone[region] = near

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The layer's largest stress and strain near the fillets (collective)."""
        if region not in self.zone:
            return {}
        near, xy = self.zone[region], self.setup.points.xy[region]
        out = {}
        if Seqv.option in self.setup.quantities:
            out["seqv_fillet_pa"] = global_max(state.comm, state.von_mises(region)[near], xy[near])
        if Eptoeqv.option in self.setup.quantities:
            out["eptoeqv_fillet"] = global_max(state.comm, state.hencky(region)[0][near], xy[near])
        return out
