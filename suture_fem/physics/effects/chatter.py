"""Nodes that swap between open and pressed within a Newton solve, held pressed for the rest of it.

With the augmented Lagrangian's pressure p = <lambda - kappa phi> (:mod:`~suture_fem.physics.effects.cone_contact`)
the set of pressed nodes is re-read at every Newton iterate. A node whose true pressure is near zero can swap
from one iterate to the next: open, Newton's step pushes it into the cone; pressed, the next step pushes it
out (measured: four frictionless cones in steps of 0.0125 of 4 N, two nodes swapping for 20 iterations while
the line search stalled at 6e-5 N, docs/contact.md). Freezing the whole set after a few iterations (FEBio's
remedy, a primal-dual active set step) removed the swapping but changed the large steps' path, where many
nodes release at once and each switches once (12x the Newton iterations on the default steps).

:class:`ChatterHold` holds only the nodes that swap: a node whose status changes :data:`SWITCHES` times
between the Jacobians of one solve is held pressed for the rest of that solve (its pressure lambda - kappa phi,
which may turn slightly negative; the residual, the Jacobian and the line search's energy all read the held
status, so the solve stays consistent). At the converged state :meth:`ChatterHold.check` compares each held
node with the law: a held node pulling on the tissue by more than the slack is held open in the next solve of
the step, a held open one pressing by more than it is held pressed; the slack is the penetration target's
pressure (kappa x ``effects.contact_penetration_mm``), so an accepted state has every node on the law's right
side to within the target. Nodes that never swap are exactly as without it.

Frictionless cones only (mu = 0): with Coulomb friction the hold stopped one cone's ramp at its first step, which
reaches 4 N without it (docs/contact.md). Holding only the pressed stiffness in the Jacobian, the law left
free, was tried too: a held node that truly opens is then moved by residual / kappa per iterate, and every
first step stopped at its iteration limit.

Hand-written: PETSc 3.18's SNES has a semi-smooth Newton for bound constraints (SNESVINEWTONSSLS), not for a
multiplier law on a searched distance assembled outside its forms.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Status changes of a node between the Jacobians of one Newton solve after which it is held.
SWITCHES = 2
#: A change of status counts only when the trial pressure lambda - kappa phi crosses this fraction of the
#: penetration target's pressure on the other side of 0: a node at p = 0 to round-off does not swap, so
#: which nodes are held does not depend on the order of a sum (one rank or two; Debian 12 or 13).
BAND = 0.1


class ChatterHold:
    """Which pairs are held within the solve under way (``held``) and in which status (``state``: pressed)."""

    def __init__(self, comm: Any, pairs: int, possible: bool, slack: float = 0.0):
        """``possible``: holding applies (frictionless cones, augmented Lagrangian); ``slack``: the target (Pa)."""
        self.comm, self.possible, self.band = comm, possible, BAND * slack
        self.held = np.zeros(pairs, dtype=bool)
        self.state = np.zeros(pairs, dtype=bool)
        self._switches = np.zeros(pairs, dtype=np.int64)
        self._last: np.ndarray | None = None
        self._carry: tuple[np.ndarray, np.ndarray] | None = None

    def begin(self, first: bool) -> None:
        """A Newton solve starts; ``first``: the first of a load step (nothing carried from another step)."""
        if first or self._carry is None:
            self.held[:], self.state[:] = False, False
        else:
            self.held, self.state = self._carry[0].copy(), self._carry[1].copy()
        self._carry, self._last = None, None
        self._switches[:] = 0

    def closed(self, trial: np.ndarray) -> np.ndarray:
        """The pressed pairs: the held ones' status, else where lambda - kappa phi is positive."""
        return np.where(self.held, self.state, trial > 0.0)

    def iterate(self, trial: np.ndarray) -> bool:
        """A Newton iterate's Jacobian: count each free pair's status changes, hold the pairs that swap.

        Returns whether a pair was held now (on any rank; collective): the law at this iterate changed.
        """
        if not self.possible:
            return False
        free = trial > 0.0
        new = np.zeros_like(free)
        if self._last is not None:
            free = np.where(np.abs(trial) > self.band, free, self._last)  # within the band: as it was
            self._switches += (free != self._last) & ~self.held
            new = (self._switches >= SWITCHES) & ~self.held
            self.held |= new
            self.state[new] = True
        self._last = free
        return bool(self.comm.allreduce(int(np.count_nonzero(new))))


    def check(self, trial: np.ndarray, slack: float) -> int:
        """At a converged state: the held pairs on the law's wrong side by more than ``slack`` (Pa; all ranks).

        Those are held in the other status in the next solve of the step.
        """
        wrong = self.held & np.where(self.state, trial < -slack, trial > slack)
        count = int(self.comm.allreduce(int(np.count_nonzero(wrong))))
        self._carry = (self.held.copy(), self.state ^ wrong) if count else None
        return count

    def keep(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the held pairs and their status (a converged state's law, kept with it)."""
        return self.held.copy(), self.state.copy()

    def restore(self, kept: tuple[np.ndarray, np.ndarray]) -> None:
        """Set what :meth:`keep` returned (a stored state, evaluated with its own law; nothing counted)."""
        self.held, self.state = kept[0].copy(), kept[1].copy()
        self._carry, self._last = None, None
        self._switches[:] = 0
