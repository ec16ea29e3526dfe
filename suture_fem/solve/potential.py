"""The energy line search's objective: the total potential energy of a static, plain displacement scene."""

from __future__ import annotations

from typing import Any

from suture_fem.support import compat


def potential_form(problem: Any) -> Any:
    """The total potential energy (strain energy minus the pull's work) as SNES's objective, or None.

    With an objective the backtracking line search asks for a decrease of the energy instead of the residual
    norm (a poor merit function where the tissue is nearly incompressible). The potential is the residual's
    only for a static, plain displacement scene without gravity (Coulomb friction adds its potential at its
    frozen bound). Measured on the paper scene (benchmarks/speed.py): P1 76 -> 38 Newton iterations per
    0-4 N ramp, same USUM to 1e-15; P2 61 -> 160 (the first step from rest fails and is cut three times),
    so it is used at degree 1 only, and at P2 where the cones are in contact or the thread's contact is
    unilateral (its penalty, and Coulomb's friction at its frozen bound, are potentials): there the residual
    norm's line search took a tenth of each Newton step and the first step from rest never converged
    (docs/contact.md, "P2 cones"); on the thread it halves the CPU of the ramp, which, with the stall rule
    lifted (:func:`~suture_fem.solve.stopping.stall_iterations`), reaches 4 N where it stopped at 0.9-1.8 N
    (docs/contact.md, "A frictionless thread the tissue may leave").
    """
    effects = getattr(problem, "effects", None)
    if effects is None or effects.mixed or effects.inertia or effects.gravity:
        return None
    contact = getattr(problem, "contact_energy", None)  # a unilateral thread's penalty
    if getattr(problem, "degree", 0) != 1 and getattr(problem, "cone_contact", None) is None and contact is None:
        return None
    traction = getattr(problem, "applied_traction", problem.traction)  # with loading.force_scale
    energy = problem.energy if contact is None else problem.energy + contact
    return compat.form(energy - traction * problem.end_displacement)
