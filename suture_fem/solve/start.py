"""A path-following start of a force ramp: the pulled end moved until it takes ``loading.start_force_n``.

Unilateral cones (docs/contact.md, "Two equilibria") release the tissue early in the pull, and under force
control the ramp's small steps stall there or invert an element. Under displacement control the end's
position is fixed in each solve, so a release cannot run away with the pull. With
``loading.start_force_n`` = F_s > 0 the force ramp therefore starts with a displacement ramp of the same
physics: the end's axial dofs fixed and moved in steps of ``loading.displacement_mm`` (its fractions
``solver.initial_step`` and ``max_step``), until the force the end takes reaches F_s. From that state the
pull switches to force control: one Newton solve under the force the end takes there balances it with the
end free (the traction's state, not the moved end's), and the force ramp goes on from that force.

Every reported state is a force ramp's state, balanced to the same tests; only the path to the first
one differs. The start's steps are not reported; its Newton iterations and cutbacks count in the ramp's.
"""

from __future__ import annotations

import logging
from types import SimpleNamespace
from typing import Any

from suture_fem.geometry.regions import MM
from suture_fem.physics.boundary import scene_constraints
from suture_fem.physics.problem import Physics
from suture_fem.scene.model import Scene
from suture_fem.solve.newton import NewtonSolver
from suture_fem.solve.paths import DisplacementRamp, LoadRamp
from suture_fem.solve.records import RampResult
from suture_fem.support.errors import SolveStopped, StopCause

log = logging.getLogger("suture_fem")


class StartRamp(DisplacementRamp):
    """The end moved until it takes ``force_n``: the path ends at the first converged state that does."""

    reports = False

    def __init__(self, physics: Physics, scene: Scene, force_n: float):
        """Steps of ``loading.displacement_mm``; no report points."""
        super().__init__(physics, scene)
        self.targets, self.end, self.force_n = [1.0], 1.0, force_n

    def accept(self, s_from: float, s_to: float) -> None:
        """Stop the path where the end takes the start's force."""
        if self.force(s_to) >= self.force_n:
            self.targets, self.end = [s_to], s_to


def displacement_start(physics: Physics, scene: Scene, result: RampResult, stepper: Any, on_converged: Any,
                       fraction: float) -> float:
    """Follow the end's displacement until it takes ``loading.start_force_n``; the force there (N, applied).

    ``stepper``: the stepping class (stepping's ``_Stepper``). The physics is left with its own (force
    control) unknowns and the state where the start ended; ``result`` gets ``start``.
    """
    force_n = scene.loading.start_force_n
    W_u = physics.W if physics.u_in_state is None else physics.W.sub(0)
    spaces = SimpleNamespace(W=physics.W, W_u=W_u, state=physics.state)
    moved = scene_constraints(physics.tagged, physics.effects, spaces, "displacement")
    own = (physics.unknowns, physics.control)
    physics.unknowns, physics.control = moved.unknowns, moved.control
    newton = NewtonSolver.of(physics, scene.solver, result.timings)
    its0 = result.newton_iterations
    path = StartRamp(physics, scene, force_n)
    steps = stepper(path, newton, result, on_converged, fraction)
    try:
        steps.run()
    finally:  # the force ramp's unknowns back, its traction that of the state the start ended in (a stop's record)
        reached, d_mm = path.force(steps.s), steps.s * path.d_max / MM
        newton.destroy()
        physics.unknowns, physics.control = own
        moved.control.destroy()
        physics.set_force(reached)
    if reached < force_n:
        raise SolveStopped.with_history(result, cause=StopCause.NEWTON_DIVERGENCE, load_reached=0.0,
                                        attempted=force_n,
                                        detail=f"the start moved the end {d_mm:g} mm (loading.displacement_mm) and it "
                                               f"took {reached:.4g} N, short of loading.start_force_n = {force_n:g} N")
    result.start = {"control": "displacement", "end_displacement_mm": d_mm, "force_n": reached,
                    "newton_iterations": result.newton_iterations - its0}
    log.info("start: the end moved %.4f mm takes %.4f N; the pull goes on under force control", d_mm, reached)
    return reached


def switch_to_force(stepper: Any, path: LoadRamp, force_n: float) -> None:
    """Balance the start's state under the force it took (the end free) and set the stepper there."""
    parameters = stepper.physics.parameters
    scale = float(parameters["loading.force_scale"].value) if parameters else 1.0
    s0 = force_n / (scale * path.f_max)
    stepper.s = s0
    path.apply(s0, s0)
    ok, its, reason = stepper._solve()
    if not ok:
        stepper._set_state(stepper.last)
        raise SolveStopped.with_history(stepper.result, cause=StopCause.NEWTON_DIVERGENCE, load_reached=0.0,
                                        attempted=path.force(s0),
                                        detail=f"the switch to force control at {path.force(s0):.4g} N failed "
                                               f"({reason} after {its} Newton iterations)")
    stepper.u_vec.copy(stepper.last)
    stepper.result.start["switch_iterations"] = its
    stepper._update_tangent()
    log.info("start: balanced under force control at %s in %d Newton iterations", path.describe(s0), its)
