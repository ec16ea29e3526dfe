"""The strain energy of the whole body (J)."""

from __future__ import annotations

from typing import Any

import dolfinx.fem
from mpi4py import MPI

from suture_fem.outputs.base import Quantity, State


class StrainEnergy(Quantity):
    """``strain_energy_j``: the assembled energy integral, summed over ranks."""

    def totals(self, state: State) -> dict[str, Any]:
        """The strain energy (collective)."""
        value = dolfinx.fem.assemble_scalar(self.setup.physics.form("energy"))
        return {"strain_energy_j": state.comm.allreduce(value, op=MPI.SUM)}
