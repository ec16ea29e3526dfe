"""Why a Newton solve failed and why a load path stopped: the cause and the human-readable text.

The cause (:class:`~suture_fem.support.errors.StopCause`, written to results.json as
``diagnosis.cause``) is decided on typed values: the guard's last
:class:`~suture_fem.solve.guard.Violation` and its :class:`~suture_fem.physics.materials.Limit`, and
whether the linear solver failed. The text names what happened, where (region, r and z in mm) and
with which value; it is logged at every cutback and becomes ``diagnosis.detail`` when the path stops.
"""

from __future__ import annotations

from typing import Any

from suture_fem.physics.materials import Limit
from suture_fem.physics.problem import Physics
from suture_fem.solve.newton import NewtonSolver
from suture_fem.support.errors import StopCause

#: The reason the stepping gives a solve that converged to a state past ``solver.gent_limit_fraction``.
PHYSICAL_LIMIT = "physical_limit"
#: The reason the stepping gives a step it cut without a solve: every start was outside the admissible domain.
INADMISSIBLE_START = "inadmissible_start"

#: What a violated limit means, as the failure text says it.
_VIOLATED = {Limit.J: "J <= 0", Limit.GENT_MARGIN: "Gent limit I1bar - 3 >= Jm",
             Limit.CONE_DEPTH: "a tissue node deeper inside a cone than the search allows (mm)"}


def stop_cause(newton: NewtonSolver) -> StopCause:
    """The cause of the last failed solve: a violated limit first, then the linear solver, else divergence."""
    v = newton.last_violation
    if v is not None:
        if v.quantity is Limit.CONE_DEPTH:  # trial states that kept going through a cone: Newton's failure
            return StopCause.NEWTON_DIVERGENCE
        return StopCause.GENT_LIMIT if v.quantity is Limit.GENT_MARGIN else StopCause.INVERTED_ELEMENT
    if newton.linear_failure():
        return StopCause.LINEAR_SOLVER
    return StopCause.NEWTON_DIVERGENCE


def failure_text(newton: NewtonSolver, reason: str, its: int) -> str:
    """What went wrong in the last solve (its SNES reason or :data:`PHYSICAL_LIMIT`, after ``its`` iterations)."""
    v = newton.last_violation
    if reason == PHYSICAL_LIMIT and v is not None:
        return (f"converged in {its} iterations, but the Gent limit is reached in the {v.region} at "
                f"r = {v.r_mm:.3f} mm, z = {v.z_mm:.3f} mm: {v.limit}")
    text = "every start of the step is outside the admissible domain" if reason == INADMISSIBLE_START else (
        f"SNES {reason} after {its} iterations")
    if v is not None:
        text += (
            f"; trial states left the admissible domain {newton.outside_domain} times ({_VIOLATED[v.quantity]} in "
            f"the {v.region} at r = {v.r_mm:.3f} mm, z = {v.z_mm:.3f} mm, value {v.value:.3g})"
        )
    if newton.linear_failure():
        text += f"; linear solver {newton.linear_solver} failed"
    return text


def advice(physics: Physics, cause: StopCause, violation: Any = None) -> str:
    """What to change, for a stop the plain displacement formulation causes ('' when there is no advice).

    A nearly incompressible tissue locks the displacement element: Newton diverges or elements invert
    under a load the mixed formulation carries (docs/hardcases.md: K x10-x1000 at P2). The contact stops
    get what carries them further, where that is known (docs/contact.md); ``violation``: the guard's last
    (:class:`~suture_fem.solve.guard.Violation`, or None), which tells a stop on the cones' wall guard.
    """
    effects = getattr(physics, "effects", None)
    if effects is None or cause not in (StopCause.NEWTON_DIVERGENCE, StopCause.INVERTED_ELEMENT):
        return ""
    degree = getattr(physics, "degree", 1)
    moved = getattr(physics, "control", None) is not None  # the pulled end already moved (displacement control)
    walled = violation is not None and violation.quantity is Limit.CONE_DEPTH
    text = _cone_advice(effects, degree, moved, walled) if effects.cone_contact else ""
    text = _base_first_advice() if effects.cone_contact and effects.thread_track and _base_first(physics) else text
    if getattr(getattr(physics, "cone_contact", None), "held", None) is not None:  # effects.cone_corners = "held"
        text = HELD_CORNERS_ADVICE
    if text:
        return text
    if effects.unilateral_thread:
        return _thread_advice(effects)
    if effects.mixed:
        return ""
    return ('; if the tissue is nearly incompressible, set effects.incompressibility = "mixed" (Taylor-Hood '
            'displacement-pressure, free of locking)' + (", or use mesh.degree = 1" if degree != 1 else ""))


def _cone_advice(effects: Any, degree: int, moved: bool, walled: bool) -> str:
    if effects.thread_track and effects.cone_interface != "sliding":  # nothing tied
        if moved:  # the end moved already: what is known of this model's reach
            return ("; with nothing tied the cones alone hold the thread: the paper's four hollow cones with a "
                    "sliding thread reach a moved end of 4 mm with Coulomb friction mu 0.3 (1.02 N, P1) and stop at "
                    "1.9 mm frictionless, where P1 tissue elements fold round a cone's corner with the tissue's next "
                    "layer held off the cone (docs/contact.md: The tissue's next layer in the search); Coulomb cones "
                    'go further than frictionless ones, and effects.thread_interface = "tied" further still')
        return ("; with nothing tied the cones alone hold the thread, and the paper's cones (apex toward the pull) "
                "hold little (one cone at P1, the end moved 4 mm: 0.25 N with a sliding thread and Coulomb cones, "
                'mu 0.3, against 0.94 N tied): follow the pull with loading.control = "displacement" '
                "(docs/contact.md: Nothing tied)")
    if degree == 2:
        return ("; the cones' contact is carried furthest by mesh.degree = 1 (the paper scene to 4 N); at P2 the "
                'trust region (solver.trust_region = "auto") and the swapping pairs\' doubled penalty carry one and '
                "four frictionless cones of the paper scene to 4 N, at 1.7 and 3.7 times P1's Newton iterations "
                "(docs/contact.md: Fewer factorisations per trust-region iteration)")
    if effects.cone_interface == "sliding" and not walled:
        return ""  # the tissue's advice, below
    if effects.cone_interface == "sliding":  # its pure penalty's penetration reached the wall guard
        return ("; the sliding cones hold the tissue by a pure penalty, whose penetration grows with the pressure "
                "until the wall guard refuses it (the paper scene's end moved 12 mm: 16.55 N with "
                "effects.contact_penalty = 100, the epidermis's Gent limit near 20 N with 300, docs/hardcases.md): "
                "raise effects.contact_penalty")
    return ("; unilateral cones stall where the tissue releases from them (a few nodes swapping between open and "
            "pressed; which state a ramp reaches is path-picked, docs/contact.md: Two equilibria): the paper scene "
            '(4 cones, P1, force control, the default steps) reaches 4 N; effects.cone_interface = "sliding" does '
            'not release; the trust region (solver.trust_region = "auto") already takes these cones\' failed solves '
            "and carries docs/hardcases.md's P1 cone cases further, at a cost (Coulomb mu 1 to 2.4 of 6 mm instead of "
            '0.11 in 4,500 Newton iterations: The trust region at P1); "off" stops sooner and cheaper')


#: A stop with the cones' corners held out of the tissue (``effects.cone_corners = "held"``).
HELD_CORNERS_ADVICE = (
    '; with the cones\' corners held (effects.cone_corners = "held") the ramps stop where the tissue slides round a '
    "cone's corner: P1 facets pass it only node by node and the elements beside it invert (the paper scene's "
    "frictionless cones in their first step, finer corners no better; docs/contact.md: The cones' corners against "
    'the tissue\'s facets); the default, "measured", solves without them and reports how deep they cut')


def _base_first(physics: Physics) -> bool:
    """Cones with their base toward the pulled end (which lies at the largest z)."""
    g = getattr(getattr(physics, "tagged", None), "geometry", None)
    return g is not None and any(c.base_z > c.apex_z for c in g.cones)


def _base_first_advice() -> str:
    return ("; with nothing tied, cones pulled base first stop on hypodermis elements folding round the base's rim "
            "(one cone, P1, the end moved: full cones at 2.7 mm frictionless and 2.9 mm Coulomb 0.3, hollow ones at "
            "3.2 and 3.5 mm); one refinement finer, mesh.refinement = 1, one full frictionless cone reaches 4 mm "
            "(docs/contact.md: The tissue's next layer in the search)")


def _thread_advice(effects: Any) -> str:
    if effects.frictional_thread:
        return ('; a Coulomb thread reaches 4 N at P2 under force control (paper scene, mu 0.1, 1 and 4 cones; '
                'mu 0.3, 1 cone), and with loading.control = "displacement" at P1 (4 cones, 4.1 N) and P2 (1 cone, '
                '8 mm)')
    return ("; the tissue opens off a frictionless thread just ahead of a cone's apex, where it stays tied to the "
            "cone, and that corner distorts (CONTACT.md: CalculiX stops there too; docs/contact.md): the paper "
            'scene reaches 4 N under force control at P1 and P2, or use effects.thread_interface = "sliding"')
