"""Central differences of the cones' contact terms, shared by the 2-D and 3-D derivative tests."""

from __future__ import annotations

from typing import Any

import numpy as np


def gradient(contact: Any, vec: Any) -> Any:
    """The terms' gradient (their residual) at ``vec``."""
    b = vec.duplicate()
    b.set(0.0)
    contact.add_residual(vec, b)
    return b


def central(contact: Any, vec: Any, step: Any) -> tuple[tuple[float, Any], tuple[float, Any]]:
    """(potential, gradient) at vec + step and at vec - step; ``vec`` is left as it was."""
    x0 = vec.copy()
    out = []
    for h in (1.0, -1.0):
        vec.waxpy(h, step, x0)
        out.append((contact.potential(vec), gradient(contact, vec)))
    x0.copy(vec)
    return out[0], out[1]


def off_the_kink(contact: Any, rng: np.random.Generator, phi: np.ndarray) -> None:
    """Multipliers as between solves, every pair 1 kPa off the pressure's kink at 0 (p = <lambda - kappa phi>)."""
    contact.multiplier[:] = 2e4 * rng.random(contact.pairs)  # Pa: pressed pairs, some also a little outside
    trial = contact.multiplier - contact.kappa * phi
    contact.multiplier[np.abs(trial) < 1e3] += 2e3


def hessian_times(contact: Any, physics: Any, vec: Any, step: Any) -> Any:
    """The terms' Jacobian at ``vec`` applied to ``step``."""
    import dolfinx.fem.petsc

    A = dolfinx.fem.petsc.create_matrix(physics.form("jacobian"))
    A.zeroEntries()
    A.assemble()
    contact.extend_pattern(A)
    A.zeroEntries()
    contact.add_jacobian(vec, A)
    applied = vec.duplicate()
    A.mult(step, applied)
    return applied


def matches(contact: Any, physics: Any, vec: Any, step: Any) -> tuple[float, float]:
    """Relative errors of the gradient against the potential's and of the Jacobian against the gradient's."""
    (ep, bp), (em, bm) = central(contact, vec, step)
    slope = gradient(contact, vec).dot(step)
    fd = bp - bm
    fd.scale(0.5)
    applied = hessian_times(contact, physics, vec, step)
    return abs((ep - em) / 2 - slope) / abs(slope), (fd - applied).norm() / applied.norm()
