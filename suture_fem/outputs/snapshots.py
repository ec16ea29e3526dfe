"""The solved state at a reported force, kept so that it can be set again after the solve.

A :class:`Snapshot` copies what the outputs of a state read and the load ramp changes: the unknowns
(ghosts included), the pull's traction, the weight's factor, a rigid suture's axial motion, a
Coulomb law's frozen bound and an augmented Lagrangian's multipliers, a moved end's displacement and,
with inertia, the time history (w_n, v_n, a_n). Restoring one makes every output, picture and
sensitivity of that state what it was when the state was reported (:meth:`suture_fem.model.Model.reports`):
the same arrays, so the same numbers, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from suture_fem.physics.effects.friction import slip_laws


def _value(constant: Any) -> Any:
    return None if constant is None else np.array(constant.value, copy=True)


def _set(constant: Any, value: Any) -> None:
    if constant is not None:
        constant.value = value


@dataclass(frozen=True)
class Snapshot:
    """One state of a physics and the loads it was solved under (local arrays, this rank's part)."""

    force_n: float
    state: np.ndarray
    traction: Any
    gravity: Any
    rigid: Any
    bound: tuple[tuple[np.ndarray, ...], ...] | None
    history: tuple[np.ndarray, ...] | None
    end: float | None = None

    @classmethod
    def take(cls, physics: Any, force_n: float) -> Snapshot:
        """Copy the current state of ``physics`` (no communication)."""
        dyn = physics.dynamics
        return cls(
            force_n=force_n,
            state=physics.state.x.array.copy(),
            traction=_value(physics.traction),
            gravity=_value(physics.gravity_factor),
            rigid=_value(physics.rigid_displacement),
            bound=tuple(law.frozen() for law in slip_laws(physics)) or None,
            history=tuple(f.x.array.copy() for f in (dyn.w_n, dyn.v_n, dyn.a_n)) if dyn is not None else None,
            end=physics.control.d if physics.control is not None else None,
        )

    def restore(self, physics: Any) -> None:
        """Set ``physics`` to this state and these loads (no communication: every rank restores its part)."""
        physics.state.x.array[:] = self.state
        physics.sync()
        _set(physics.traction, self.traction)
        _set(physics.gravity_factor, self.gravity)
        _set(physics.rigid_displacement, self.rigid)
        if self.bound is not None:
            for law, kept in zip(slip_laws(physics), self.bound):
                law.thaw(kept)
        if self.end is not None:  # displacement control: where the pulled end was
            physics.control.set(self.end)
        if self.history is not None:
            dyn = physics.dynamics
            for f, kept in zip((dyn.w_n, dyn.v_n, dyn.a_n), self.history):
                f.x.array[:] = kept
