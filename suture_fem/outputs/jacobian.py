"""The range of the volume ratio J = det F over each region's quadrature points."""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

from suture_fem.outputs.base import POINT_OUTPUTS, Quantity, State


class JRange(Quantity):
    """``j_range``: [min J, max J] over a region's quadrature points (None where the region has none).

    Computed whenever the stress or strain outputs are, from the same point fields.
    """

    @classmethod
    def wanted(cls, quantities: tuple[str, ...]) -> bool:
        """Whether SEQV or EPTOEQV is asked for."""
        return bool(POINT_OUTPUTS & set(quantities))

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The region's J range (collective)."""
        jac = state.hencky(region)[1]
        jmin = state.comm.allreduce(float(np.min(jac, initial=np.inf)), op=MPI.MIN)
        jmax = state.comm.allreduce(float(np.max(jac, initial=-np.inf)), op=MPI.MAX)
        return {"j_range": [jmin, jmax] if np.isfinite(jmin) else None}
