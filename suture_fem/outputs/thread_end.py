"""The axial displacement of the thread's pulled end face (mm), for the force-displacement curve."""

from __future__ import annotations

from typing import Any

import dolfinx.fem
from mpi4py import MPI

from suture_fem.geometry.regions import MM
from suture_fem.outputs.base import Quantity, State


class ThreadEnd(Quantity):
    """``thread_end_displacement_mm``: the 2 pi r-weighted mean axial displacement of the pulled end face."""

    def value(self) -> float:
        """The end face's mean axial displacement, mm (collective)."""
        physics = self.setup.physics
        val = dolfinx.fem.assemble_scalar(physics.form("end_displacement"))
        return physics.comm.allreduce(val, op=MPI.SUM) / physics.pull_area / MM

    def totals(self, state: State) -> dict[str, Any]:
        """The end face's displacement (collective)."""
        return {"thread_end_displacement_mm": self.value()}
