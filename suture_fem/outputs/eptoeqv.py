"""EPTOEQV: the maximum equivalent Hencky strain, per region, and the same maximum outside the rims.

sqrt(2/3 dev(h):dev(h)) with the Hencky strain h = 1/2 ln B (ANSYS's equivalent strain with effective
Poisson ratio 0.5), at the quadrature points of the energy integral; outside the rims as for SEQV.
"""

from __future__ import annotations

from typing import Any

from suture_fem.outputs.base import Quantity, State, global_max
from suture_fem.scene.schema import OutputSection


class Eptoeqv(Quantity):
    """EPTOEQV (``eptoeqv``) and EPTOEQV outside the rims (``eptoeqv_outside_rim``), with their points."""

    option = "eptoeqv"

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where the maximum is taken."""
        return {"eptoeqv": "maximum over quadrature points of the energy integral; MESH-DEPENDENT where it sits at a "
                "sharp corner (a singularity), not a material strain: compare eptoeqv_fillet and eptoeqv_cd"}

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The region's maximum equivalent strain, everywhere and outside the rims (collective)."""
        points = self.setup.points
        strain, xy, far = state.hencky(region)[0], points.xy[region], points.outside_rims[region]
        return {
            "eptoeqv": global_max(state.comm, strain, xy),
            "eptoeqv_outside_rim": global_max(state.comm, strain[far], xy[far]),
        }
