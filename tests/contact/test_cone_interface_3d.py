"""The cones' contact in 3-D (the half model): the terms' gradient and Hessian against finite differences of their
potential on the coarse cylinder of tests/integration/test_three_d_run.py, the search moving as the state moves.

The frictionless cones' terms are checked here too: before the trust region carried them (docs/three-d.md, "The
unilateral cones") their solve stopped at 0.21 of 0.5 N on this cylinder, and what stopped it was not their
derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from tests.contact.differences import matches, off_the_kink
from tests.integration.test_three_d_run import COARSE_3D


def _physics(model: str):
    """The coarse cylinder's physics with the cones' ``model``."""
    from suture_fem import Model
    from suture_fem.scene.load import parse_scene

    values = [v for v in COARSE_3D if not v.startswith("output.")]
    scene = parse_scene("paper", [*values, f'effects.cone_interface="{model}"'])
    return Model(scene, checked=True).physics


@pytest.mark.parametrize("model", ["sliding", "frictionless"])
def test_the_3d_cone_terms_are_the_derivatives_of_their_potential(model):
    """Each tissue node's three dofs: the meridian gradient and Hessian carried to space, the hoop term included."""
    from suture_fem.support import compat

    physics = _physics(model)
    contact = physics.cone_contact
    assert contact.dofs.shape[1] == 3
    rng = np.random.default_rng(1)
    physics.state.x.array[:] = 2e-5 * rng.standard_normal(physics.state.x.array.shape)  # 20 um: pairs pressed, open
    physics.state.x.scatter_forward()
    vec = compat.function_vector(physics.state)
    phi = contact.search(vec)["phi"]
    assert np.count_nonzero(phi < 0) > 20 and np.count_nonzero(phi > 0) > 20
    if contact.augmented:  # frictionless: the multipliers as between solves
        off_the_kink(contact, rng, phi)
    step = vec.duplicate()
    step.setArray(1e-9 * rng.standard_normal(step.getLocalSize()))
    slope_error, hessian_error = matches(contact, physics, vec, step)
    assert slope_error <= 1e-6 and hessian_error <= 1e-6
