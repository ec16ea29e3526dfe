"""SEQV: the maximum von Mises stress (Pa), per region, and the same maximum outside the rims.

The stress is the full 3x3 Cauchy stress sigma = J^-1 P F^T, hoop component included, at the
quadrature points of the energy integral. SEQV outside the rims is the same maximum over the points
farther than ``output.rim_exclusion_mm`` from every cone corner and from the two points where the
thread crosses the tissue's end faces (all re-entrant corners of the suture-tissue interface). The
sharp-corner peak is a singularity; this measure is not, but it still depends on the mesh
(docs/ledger.md measures how much).
"""

from __future__ import annotations

from typing import Any

from suture_fem.outputs.base import Quantity, State, global_max
from suture_fem.scene.schema import OutputSection


class Seqv(Quantity):
    """SEQV (``seqv_pa``) and SEQV outside the rims (``seqv_outside_rim_pa``), with their points."""

    option = "seqv"

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where the maxima are taken."""
        return {
            "seqv_pa": "maximum over quadrature points of the energy integral; MESH-DEPENDENT where it sits at a "
            "sharp corner (a singularity: it grows with every refinement), not a material stress: compare "
            "seqv_fillet_pa and seqv_cd_pa",
            "seqv_outside_rim_pa": f"as seqv_pa, over points farther than {output.rim_exclusion_mm:g} mm "
            "from every cone corner and from where the thread crosses the tissue's end faces",
        }

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The region's maximum von Mises stress, everywhere and outside the rims (collective)."""
        points = self.setup.points
        vm, xy, far = state.von_mises(region), points.xy[region], points.outside_rims[region]
        return {
            "seqv_pa": global_max(state.comm, vm, xy),
            "seqv_outside_rim_pa": global_max(state.comm, vm[far], xy[far]),
        }
