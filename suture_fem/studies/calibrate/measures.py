"""The tissue's converged stress measures at a converged state, and their derivatives along du/dp.

The measures are those results.json reports for the tissue (:mod:`suture_fem.outputs.critical_distance`):
the von Mises stress (``seqv_cd_pa``) and the equivalent Hencky strain (``eptoeqv_cd``) averaged over
a disc of radius ``output.critical_distance_mm``, at the disc centre where the average is largest.

Their derivative with respect to a parameter p needs no extra solve: the measure S(u, p) depends on p
through the state (u, whose derivative du/dp the direct method gives) and, for a material constant or
the tissue scale, directly through the stress law. So

    dS/dp = [S(u + h du/dp, p + h) - S(u - h du/dp, p - h)] / (2 h),

a central difference of the output map only (h = :data:`STEP` times |p|), with S evaluated at the
disc centre found at the converged state: the centre is the argmax over a grid fixed in space, so under
a small change of p it stays where it is and the derivative of the maximum is that of the average at
that centre (the envelope theorem; a tie between two centres would make the maximum's derivative
one-sided). The output map is smooth in (u, p) (the stress law's closed form), so the difference's
error is O(h^2) and its round-off about 1e-16 / h relative.
"""

from __future__ import annotations

import numpy as np

from suture_fem.geometry.regions import MM, WHOLE_TISSUE
from suture_fem.outputs.base import Setup, State
from suture_fem.outputs.critical_distance import FIELDS, CriticalDistance
from suture_fem.outputs.disc import overlap_averages
from suture_fem.physics.problem import Physics
from suture_fem.scene.schema import OutputSection

#: Relative step of the output map's central difference (no solve: only the stress law is evaluated).
STEP = 1e-4


class TissueMeasures:
    """The tissue's critical-distance averages of one physics (compiled once), and their derivatives."""

    def __init__(self, physics: Physics, output: OutputSection):
        """The stress and strain expressions and the tissue's disc averaging, built once."""
        if output.critical_distance_mm <= 0:
            raise ValueError("the tissue's stress measure needs output.critical_distance_mm > 0")
        self.physics = physics
        self.setup = Setup(physics, output, ("seqv", "eptoeqv"))
        self.cd = CriticalDistance(self.setup)
        self.field_of = {name: fn for name, _, fn in FIELDS}

    def maximum(self, name: str) -> tuple[float, list[float] | None]:
        """(the measure, its disc centre in mm) at the current state (collective)."""
        found = self.cd.in_tissue(State(self.setup))[name]
        return float(found.value), found.at_mm

    def at_centre(self, name: str, centre_mm: list[float]) -> float:
        """The disc average of the measure's field around a fixed centre (mm), at the current state (collective)."""
        field, _ = self.cd.field(State(self.setup), WHOLE_TISSUE, self.field_of[name])
        return float(overlap_averages(field, np.array([centre_mm], dtype=float) * MM, self.cd.radius)[0])

    def derivative(self, name: str, centre_mm: list[float], key: str, change: np.ndarray) -> float:
        """dS/dp along the state's derivative ``change`` (du/dp as the state's local array), p = ``key``.

        The state and the parameter are restored afterwards; the change's ghosts are those of the
        state (:meth:`~suture_fem.studies.calibrate.sensitivity.Sensitivity.state_derivatives`).
        """
        p = self.physics
        saved = p.state.x.array.copy()
        constant = p.parameters.get(key)
        p0 = float(constant.value) if constant is not None else 1.0
        h = STEP * max(abs(p0), 1e-300)
        sides = []
        try:
            for sign in (1.0, -1.0):
                p.state.x.array[:] = saved + sign * h * change
                p.sync()
                if constant is not None:
                    p.set_parameter(key, p0 + sign * h)
                sides.append(self.at_centre(name, centre_mm))
        finally:
            p.state.x.array[:] = saved
            p.sync()
            if constant is not None:
                p.set_parameter(key, p0)
        return (sides[0] - sides[1]) / (2 * h)
