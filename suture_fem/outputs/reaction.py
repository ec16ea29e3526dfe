"""The reaction of the fixed outer surface and the residual left at the free degrees of freedom.

Both come from one assembly of the residual without boundary conditions: at the fixed outer-surface
dofs it is the axial force of the fixed surface on the tissue (at equilibrium minus the applied
force); at the unconstrained dofs it is what equilibrium leaves over, which bounds the force balance
error. The terms assembled by hand (a Coulomb thread's friction, the cones' contact) are part of that
residual, as in the Newton solve: without them a pressed cone's contact forces counted as imbalance
(1.27 N left over at 4 N, one frictionless cone).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

from suture_fem.outputs.base import Quantity, State
from suture_fem.physics.constraints import FREE
from suture_fem.physics.effects.friction import full_residual


class Reaction(Quantity):
    """``reaction_force_n``, ``free_residual_norm_n`` (N) and ``force_balance_rel`` = |reaction + F| / F."""

    def forces(self) -> tuple[float, float]:
        """(axial force of the fixed outer surface on the body, residual norm at the free dofs), N (collective)."""
        physics = self.setup.physics
        b = full_residual(physics)
        n_owned = b.getLocalSize()
        owned = physics.outer_z_dofs[physics.outer_z_dofs < n_owned]
        local = float(np.sum(b.array[owned]))
        unknowns = physics.unknowns
        free = unknowns.kind[:n_owned] == FREE  # not held by a boundary condition, the reduction, the track
        local_sq = float(np.sum(b.array[free] ** 2))
        if unknowns.hoop is not None:  # a sliding track node's equation along its hoop direction t (3-D)
            mine = unknowns.hoop[:, 0] < n_owned
            pairs, t = unknowns.hoop[mine], unknowns.hoop_dirs[mine]
            local_sq += float(np.sum((t[:, 0] * b.array[pairs[:, 0]] + t[:, 1] * b.array[pairs[:, 1]]) ** 2))
        b.destroy()
        comm = physics.comm
        return comm.allreduce(local, op=MPI.SUM), float(np.sqrt(comm.allreduce(local_sq, op=MPI.SUM)))

    def totals(self, state: State) -> dict[str, Any]:
        """The reaction, the free residual norm and the relative force balance (collective)."""
        reaction, free_norm = self.forces()
        return {
            "reaction_force_n": reaction,
            "free_residual_norm_n": free_norm,
            "force_balance_rel": abs(reaction + state.force_n) / max(state.force_n, 1e-300),
        }
