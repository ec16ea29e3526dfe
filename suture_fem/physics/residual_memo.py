"""The residual :func:`~suture_fem.physics.effects.friction.full_residual` assembled last, with what it read.

The residual form's value is a function of its coefficients (the state's Functions) and its constants
(the loads, the material constants) alone, on a fixed mesh. A caller that asks for the residual without a
vector of its own (the reaction at a reported state, the end force under displacement control) gets the
values the Newton solver assembled last when every coefficient and constant is, bit for bit, what that
assembly read: at a converged state the solver's last residual is at that very state (the outputs'
reaction at every report then costs no assembly). Anything else (a changed load, another state) and it is
assembled afresh. Kept only for a residual without nodal terms (friction, the cones' contact): what those
hold between solves is not among the form's inputs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI


class ResidualMemo:
    """The owned entries of the residual last assembled into a caller's vector, and the form's inputs then."""

    def __init__(self, form: Any, comm: Any):
        """For the UFL ``form`` (its coefficients and constants are read at every keep and recall)."""
        self.coefficients = list(form.coefficients())
        self.constants = list(form.constants())
        self.comm = comm
        self._key: np.ndarray | None = None
        self._values: np.ndarray | None = None

    def _inputs(self) -> np.ndarray:
        """Every coefficient's local array and every constant's value, as one float array."""
        parts = [np.asarray(c.x.array, dtype=np.float64).ravel() for c in self.coefficients]
        parts += [np.asarray(c.value, dtype=np.float64).ravel() for c in self.constants]
        return np.concatenate(parts) if parts else np.zeros(0)

    def keep(self, b: Any) -> None:
        """Keep ``b``'s owned entries (just assembled) with the inputs they were assembled from."""
        self._key = self._inputs()
        self._values = b.getArray(readonly=True).copy()

    def recall(self) -> np.ndarray | None:
        """The kept owned entries when every input is bit for bit what it was (collective); else None."""
        key = self._key
        if key is None:
            same = False
        else:
            now = self._inputs()
            same = now.shape == key.shape and bool(np.array_equal(now.view(np.int64), key.view(np.int64)))
        if self.comm.size > 1:
            same = bool(self.comm.allreduce(same, op=MPI.LAND))
        return self._values if same else None
