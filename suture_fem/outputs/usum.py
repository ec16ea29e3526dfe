"""USUM: the maximum of |u| over the displacement nodes (mm), per region."""

from __future__ import annotations

from typing import Any

import numpy as np

from suture_fem.geometry.regions import MM
from suture_fem.outputs.base import Quantity, State, global_max
from suture_fem.scene.schema import OutputSection


class Usum(Quantity):
    """USUM (``usum_mm``): the maximum of |u| over a region's displacement nodes, with its node."""

    option = "usum"

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where the maximum is taken."""
        return {"usum_mm": "maximum over displacement nodes"}

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The region's maximum displacement magnitude (collective)."""
        nodes = self.setup.region_nodes[region]
        u = self.setup.physics.u.x.array.reshape(-1, self.setup.physics.mesh.geometry.dim)
        magnitude = np.linalg.norm(u[nodes], axis=1) / MM
        return {"usum_mm": global_max(state.comm, magnitude, self.setup.node_xy[nodes])}
