"""The cones' unilateral penalty in the trust region's model: each open pair's term on its linearised gap.

The trust region (:mod:`suture_fem.solve.trust`) models the energy by its second-order expansion at the iterate.
A pair that is open there (p = <lambda - kappa phi> = 0) has no term in that expansion, so a step that presses
it into its cone is predicted to cost nothing, while the energy gains w <lambda - kappa phi>^2 / (2 kappa). The
trust region refuses such a step, shrinks its radius, and the pair approaches its cone a fraction of its gap at
a time: four P2 frictionless cones' first step from rest took 200 iterations without converging, the refused
steps pressing one tissue node 0.3 um off an apex corner (docs/contact.md, "The trust region's model of the
open pairs").

Here the model keeps each open pair's term on its linearised gap phi + n . dy (dy the pair's move relative to
its cone, the node's own less the cone's mean axial move): a piecewise quadratic. Its step is found as a
primal-dual active set method finds one (Hintermueller, Ito & Kunisch, SIAM J. Optim. 13, 2002): the pairs
that the last step presses join the model's Hessian (kappa w n n^T) and gradient (-w (lambda - kappa phi) n),
the step is solved again, until no pair joins. Pairs closed at the iterate keep the expansion's terms. 2-D
only (the unilateral cones are refused in 3-D).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc


class GapModel:
    """The open pairs of a :class:`~.cone_contact.ConeContact` in the trust region's model (collective)."""

    def __init__(self, contact: Any, reduction: Any):
        """``reduction``: the Newton solve's u = T x + g (:class:`~suture_fem.solve.reduction.Reduction`)."""
        self.contact, self.reduction = contact, reduction
        self.move = reduction.T.createVecLeft()  # a step's full-space move T p
        self.phi = np.zeros(contact.pairs)
        self.n = np.zeros((contact.pairs, 2))
        self.open = np.zeros(contact.pairs, dtype=bool)

    @classmethod
    def of(cls, physics: Any, reduction: Any) -> GapModel | None:
        """The model of ``physics``'s unilateral cones in 2-D, else None."""
        contact = getattr(physics, "cone_contact", None)
        if contact is None or contact.bilateral or physics.mesh.geometry.dim != 2:
            return None
        return cls(contact, reduction)

    def at(self, state: Any) -> None:
        """Take the iterate ``state`` (the full PETSc vector) as the model's centre: its gaps, normals, open pairs."""
        found = self.contact.search(state)
        self.phi[:], self.n[:] = found["phi"], found["n"]
        self.open[:] = ~self.contact._pressure(self.phi)[1]

    def change(self, p: Any) -> np.ndarray:
        """Each pair's linearised gap change n . dy under the step ``p`` (the reduced unknowns' step), m."""
        contact = self.contact
        self.reduction.T.mult(p, self.move)
        contact._scatter.scatter(self.move, contact._local, addv=PETSc.InsertMode.INSERT,
                                 mode=PETSc.ScatterMode.FORWARD)
        du, dt_c = contact.moves(contact._local.getArray(readonly=True))
        dy = du.copy()
        dy[:, 1] -= dt_c[contact.cone]  # relative to the cone, which moves axially by t_c
        return np.sum(self.n * dy, axis=1)

    def pressed(self, change: np.ndarray) -> np.ndarray:
        """The open pairs that a step of gap change ``change`` presses."""
        return self.open & self.contact._pressure(self.phi + change)[1]

    def add(self, joined: np.ndarray, A: Any, b: Any) -> None:
        """Add the ``joined`` pairs' terms to the full Jacobian ``A`` and residual ``b`` (assembled; collective)."""
        contact = self.contact
        w = np.where(joined, contact.weight, 0.0)
        hess = (contact.penalty * w)[:, None, None] * (self.n[:, :, None] * self.n[:, None, :])
        contact._layout.add(A, hess)
        A.assemble()
        grad = -(w * (contact.multiplier - contact.penalty * self.phi))[:, None] * self.n  # p unclipped: open
        contact._layout.add_gradient(b, grad, grad[:, 1])
        b.assemble()

    def energy(self, change: np.ndarray) -> float:
        """The open pairs' terms at the gap change ``change``: sum w <lambda - kappa (phi + dphi)>^2 / (2 kappa), J."""
        contact = self.contact
        p = contact._pressure(self.phi + change)[0]
        local = float(np.sum(np.where(self.open, 0.5 * contact.weight * p**2 / contact.penalty, 0.0)))
        return float(contact.comm.allreduce(local, op=MPI.SUM))

    def any(self, mask: np.ndarray) -> bool:
        """Whether ``mask`` holds anywhere (every rank's answer)."""
        return bool(self.contact.comm.allreduce(bool(np.any(mask)), op=MPI.LOR))
