"""The cones' contact in 3-D (the half model): the terms' gradient and Hessian against finite differences of their
potential on the coarse cylinder of tests/integration/test_three_d_run.py, the search moving as the state moves.

The frictionless cones are refused in 3-D (their solve stopped at 0.21 of 0.5 N on this cylinder, docs/three-d.md);
their terms are checked here too, built past the refusal: what stops is not their derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from tests.integration.test_three_d_run import COARSE_3D


def _physics(model: str):
    """The coarse cylinder's physics; past the 3-D refusal of the frictionless cones (their solve is what stops)."""
    from suture_fem import Model
    from suture_fem.scene.load import parse_scene

    values = [v for v in COARSE_3D if not v.startswith("output.")]
    scene = parse_scene("paper", [*values, f'effects.cone_interface="{model}"'])
    return Model(scene, checked=True).physics


@pytest.mark.parametrize("model", ["sliding", "frictionless"])
def test_the_3d_cone_terms_are_the_derivatives_of_their_potential(model):
    """Each tissue node's three dofs: the meridian gradient and Hessian carried to space, the hoop term included."""
    import dolfinx.fem.petsc

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
    if contact.augmented:  # frictionless: the multipliers as between solves, every pair 1 kPa off p's kink at 0
        contact.multiplier[:] = 2e4 * rng.random(contact.pairs)
        trial = contact.multiplier - contact.kappa * phi
        contact.multiplier[np.abs(trial) < 1e3] += 2e3
    x0, step = vec.copy(), vec.duplicate()
    step.setArray(1e-9 * rng.standard_normal(step.getLocalSize()))
    grad = vec.duplicate()
    grad.set(0.0)
    contact.add_residual(vec, grad)

    def at(h):
        vec.waxpy(h, step, x0)
        energy, b = contact.potential(vec), vec.duplicate()
        b.set(0.0)
        contact.add_residual(vec, b)
        return energy, b

    (ep, bp), (em, bm) = at(1.0), at(-1.0)
    x0.copy(vec)
    assert (ep - em) / 2 == pytest.approx(grad.dot(step), rel=1e-6)
    A = dolfinx.fem.petsc.create_matrix(physics.form("jacobian"))
    A.zeroEntries()
    A.assemble()
    contact.extend_pattern(A)
    A.zeroEntries()
    contact.add_jacobian(vec, A)
    applied = vec.duplicate()
    A.mult(step, applied)
    fd = bp - bm
    fd.scale(0.5)
    assert (fd - applied).norm() <= 1e-6 * applied.norm()
