"""What a 3-D scene (``geometry.dimension = 3``) may call for, and the slab's own checks, before meshing.

The 3-D model is the cylinder or the slab half model (:mod:`suture_fem.geometry.gmsh_3d`): the same materials, sharp
or rounded rims, the tied, sliding, frictionless or Coulomb cones (the unilateral ones with the trust region and the
swapping pairs' doubled penalty: docs/three-d.md), the tied, frictionless, sliding or Coulomb thread, the elastic or
the rigid suture, the displacement or the mixed formulation, gravity along the thread, the pull as a force on the
thread's end face or its end moved (displacement control), the static load ramp or inertia's time history, the field
files, the load shares, straight or quadratic (curved) cells, and the USUM, SEQV and EPTOEQV maxima (with the
reaction, energy and end displacement) and their critical-distance averages over a ball
(:mod:`suture_fem.outputs.ball_search`). Every scene key a 2-D scene has is built in 3-D; what is checked here is the
slab's: its shape needs 3-D, and its outputs need the slab.
"""

from __future__ import annotations

from typing import Any

from suture_fem.scene.schema import OUTPUT_QUANTITIES, SLAB_QUANTITIES
from suture_fem.support.errors import SceneError


def check_three_d(scene: Any) -> None:
    """SceneError (one line naming the key) for the slab's keys where there is no slab.

    ``geometry.tissue_shape = "slab"`` needs ``geometry.dimension = 3``, and the slab's outputs (``output.quantities``'
    "dimple") need the slab.
    """
    slab_outputs = [q for q in SLAB_QUANTITIES if q in scene.output.quantities]
    if scene.geometry.tissue_shape != "slab" and slab_outputs:
        others = ", ".join(q for q in OUTPUT_QUANTITIES if q not in SLAB_QUANTITIES)
        raise SceneError(f'scene key output.quantities = {list(scene.output.quantities)}: "{slab_outputs[0]}" (the '
                         "skin surface's displacement) needs geometry.tissue_shape = \"slab\" and geometry.dimension "
                         f"= 3; allowed here: any of {others}")
    if scene.geometry.dimension != 3 and scene.geometry.tissue_shape != "cylinder":
        raise SceneError('scene key geometry.tissue_shape = "slab" needs geometry.dimension = 3; allowed in 2-D: '
                         '"cylinder"')
