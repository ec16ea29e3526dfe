"""The cones' corners against the tissue's facets (``effects.cone_corners``; physics/effects/cone_corners.py).

Checked here: at rest every corner lies inside its cone, off the tissue; a cone moved ahead of the tissue puts its
apex corner inside the tissue by the move less that offset (a closed form), measured and reported, and a tissue
maximum within the critical distance of it is named (not one too far, in the suture, or USUM); held, the
corners' terms are the derivatives of their potential (gradient and the exact Hessian against central
differences, the nearest facet moving as the state moves, beside a piece and off a node) and push the facet into
the tissue and the cone back; a scene holding the corners of cones that are not unilateral is refused before
meshing; two ranks hold them as one does.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import run_paper
from tests.contact.differences import matches, off_the_kink


def _moved(held: bool, move_m: float):
    """A one-cone paper model (P1, frictionless) with the cone moved ``move_m`` toward the pull, the tissue at rest."""
    from petsc4py import PETSc

    from suture_fem import Model, Scene
    from suture_fem.support import compat

    scene = Scene.builtin("paper").with_values({"geometry.cones": 1, "mesh.degree": 1, "mesh.refinement": 0,
                                                "effects.cone_interface": "frictionless",
                                                "effects.cone_corners": "held" if held else "measured"})
    physics = Model(scene).physics
    contact = physics.cone_contact
    vec = compat.function_vector(physics.state)
    rest = contact.corners.search(vec, np.zeros(1))["d"].copy()
    vec.setValues(contact.cone_dofs[0].astype(PETSc.IntType), np.full(len(contact.cone_dofs[0]), move_m))
    vec.assemble()
    return physics, contact, vec, rest


def test_a_cone_moved_ahead_puts_its_apex_corner_inside_the_tissue_by_the_move():
    physics, contact, vec, rest = _moved(held=False, move_m=1e-4)
    corners, cone = contact.corners, physics.tagged.geometry.cones[0]
    assert contact.held is None and corners.count == 3  # hollow: the apex cap's corner, the base's outer and inner rims
    assert np.all(rest > 1e-6)  # at rest each rounded corner lies inside the cone, a few um off the tissue
    apex = int(np.argmax(corners.C[:, 1]))
    assert rest[apex] == pytest.approx((cone.apex_z - corners.C[apex, 1]) * 1e-3, rel=1e-9)  # under the cap's face
    status = contact.status(vec)
    assert status["corners_inside_tissue"] == 2  # the apex corner and the base's outer rim (the flank widens down)
    assert status["corner_penetration_max_mm"] == pytest.approx(0.1 - rest[apex] / 1e-3, rel=1e-9)
    notes = physics.notes["interfaces"]
    assert notes["cone_contact_corners"] == 3 and "measured" in notes["cone_contact_corner_search"]
    b = vec.duplicate()
    contact.add_residual(vec, b)
    held_physics, held, held_vec, _ = _moved(held=True, move_m=1e-4)
    c = held.search(held_vec)["t_c"]
    found = held.corners.search(held_vec, c)
    a_node, b_node = held.corners.pieces[found["piece"][apex]]
    assert held.held is held.corners and found["n"][apex] == pytest.approx([0.0, -1.0], abs=1e-9)  # the cap's
    with_corners = held_vec.duplicate()
    held.add_residual(held_vec, with_corners)
    with_corners.axpy(-1.0, b)  # the corner's own terms: the cap's facet pushed up (into the tissue), the cone down
    push = with_corners.getValues(held.corners.nodes[[a_node, b_node], 1].astype(np.int32))
    cone_back = with_corners.getValues(held.cone_dofs[0].astype(np.int32))
    assert np.all(push <= 0.0) and push.sum() < 0.0 and np.all(cone_back > 0.0)  # residual = -force
    axial = np.union1d(held.corners.nodes[:, 1], held.cone_dofs[0])  # the facets' (a junction's is the cone's too)
    total = with_corners.getValues(axial.astype(np.int32)).sum()
    assert abs(total) <= 1e-12 * cone_back.sum()  # action and reaction: no net axial force


def test_a_tissue_maximum_near_a_cutting_corner_is_named():
    from suture_fem.outputs.cone_gaps import maxima_near_cut_corners

    physics, contact, vec, rest = _moved(held=False, move_m=1e-4)
    apex, cap = int(np.argmax(contact.corners.C[:, 1])), physics.tagged.geometry.cones[0].apex_z
    r, z = contact.corners.C[apex]  # the tissue it cuts: on the cap's facet at r, where it was at rest
    record = {"seqv_cd_pa_at_mm": [r - 0.15, z], "seqv_cd_pa_region": "tissue",  # 0.15 mm off: within 0.1 + 0.096
              "eptoeqv_cd_at_mm": [r, z + 0.3], "eptoeqv_cd_region": "tissue",  # too far
              "seqv_pa_at_mm": [r - 0.1, z], "seqv_pa_region": "suture",  # not the tissue's
              "usum_mm_at_mm": [r, z], "usum_mm_region": "hypodermis"}  # a displacement, not a stress
    near = maxima_near_cut_corners(record, contact, vec, radius_mm=0.1)
    assert [item["measure"] for item in near] == ["seqv_cd_pa"] and near[0]["cone"] == "cone_1"
    assert near[0]["tissue_at_mm"] == pytest.approx([r, cap], abs=1e-12)
    assert near[0]["distance_mm"] == pytest.approx(np.hypot(0.15, cap - z), rel=1e-12)
    assert near[0]["corner_penetration_mm"] == pytest.approx(0.1 - rest[apex] / 1e-3, rel=1e-9)
    assert maxima_near_cut_corners(record, contact, vec.duplicate(), radius_mm=0.1) == []  # at rest nothing cuts


def test_held_corners_terms_are_the_derivatives_of_their_potential():
    """Central differences of the potential and the gradient with the apex corner 16 um inside the tissue."""
    physics, contact, vec, _ = _moved(held=True, move_m=2e-5)
    rng = np.random.default_rng(2)
    noise = vec.duplicate()
    noise.setArray(1e-7 * rng.standard_normal(noise.getLocalSize()))
    vec.axpy(1.0, noise)
    found = contact.corners.search(vec, contact.search(vec)["t_c"])
    assert np.count_nonzero(found["d"] < -1e-5) == 1  # the apex corner, beside the cap's facet
    off_the_kink(contact, rng, contact.search(vec)["phi"])
    contact.held.multiplier[:] = 3e4  # Pa: the corners' multipliers as between solves; the open rims stay open
    step = vec.duplicate()
    step.setArray(1e-10 * rng.standard_normal(step.getLocalSize()))
    slope_error, hessian_error = matches(contact, physics, vec, step)
    assert slope_error <= 1e-6 and hessian_error <= 1e-6


def test_holding_the_corners_of_cones_that_are_not_unilateral_is_refused():
    from suture_fem import Scene
    from suture_fem.physics.effects.record import check_scene  # what Model and the CLI run before meshing
    from suture_fem.support.errors import SceneError

    for model in ("tied", "sliding"):
        scene = Scene.builtin("paper").with_values({"effects.cone_interface": model, "effects.cone_corners": "held"})
        with pytest.raises(SceneError, match=r'effects.cone_corners = "held" needs effects.cone_interface'):
            check_scene(scene)
    check_scene(Scene.builtin("paper").with_values({"effects.cone_interface": "coulomb",
                                                    "effects.cone_corners": "held"}))  # allowed


#: A pull the held corners carry on the one-cone scene (P1, refinement 0): its ramps stop near 0.007 N, where the
#: tissue starts to pass the apex corner node by node (docs/contact.md).
HELD_PULL_N = 0.005


def test_two_ranks_hold_the_corners_as_one_does(tmp_path_factory):
    """The corners' terms are searched on every rank and added on rank 0: two ranks give the serial answer."""
    held = ["mesh.degree=1", "mesh.refinement=0", "geometry.cones=1", 'effects.cone_interface="frictionless"',
            'effects.cone_corners="held"', f"loading.force_n={HELD_PULL_N}",
            f"loading.report_forces_n=[{HELD_PULL_N / 2},{HELD_PULL_N}]", 'output.quantities=["usum","interface"]']
    one, two = (run_paper(tmp_path_factory, f"held{n}", held, ranks=n) for n in (1, 2))
    assert two["mpi_ranks"] == 2 and len(one["at_forces"]) == len(two["at_forces"]) == 2
    for a, b in zip(one["at_forces"], two["at_forces"]):
        ca, cb = a["interface"]["cone_contact"], b["interface"]["cone_contact"]
        # measured (Debian 12): USUM, the shares and the apex corner's depth equal to 1e-13
        assert b["usum_mm"] == pytest.approx(a["usum_mm"], rel=1e-9)
        for name in a["load_share_n"]:
            assert b["load_share_n"][name] == pytest.approx(a["load_share_n"][name], abs=1e-9 * HELD_PULL_N)
        assert cb["corners_inside_tissue"] == ca["corners_inside_tissue"] == 1  # the apex corner, held to the target
        target = one["effects"]["interfaces"]["contact_penetration_target_mm"]  # the multipliers' target
        assert ca["corner_penetration_max_mm"] <= target
        assert cb["corner_penetration_max_mm"] == pytest.approx(ca["corner_penetration_max_mm"], rel=1e-6)


def test_held_corners_terms_are_the_derivatives_of_their_potential_off_a_node():
    """The apex corner inside the tissue with a node of its facets nearest: the distance's bending in the Hessian.

    The tissue's facets on the cone moved 20 um toward the axis and 20 um against the pull put the apex corner
    diagonally off the node at the cap's corner, inside the tissue (the tissue wraps the corner there). Measured:
    gradient 3e-10 and Hessian 6e-10 off; with the bending left out the Hessian was 0.14 off.
    """
    from petsc4py import PETSc

    from suture_fem.physics.effects.cone_corners import BENDING_FLOOR

    physics, contact, vec, rest = _moved(held=True, move_m=0.0)
    corners = contact.corners  # one cone, serial: its chain's nodes all local
    vec.setValues(corners.nodes.ravel().astype(PETSc.IntType), np.full(corners.nodes.size, -2e-5))
    vec.assemble()
    rng = np.random.default_rng(3)
    noise = vec.duplicate()
    noise.setArray(1e-7 * rng.standard_normal(noise.getLocalSize()))
    vec.axpy(1.0, noise)
    found = corners.search(vec, contact.search(vec)["t_c"])
    apex = int(np.argmax(corners.C[:, 1]))
    assert not found["interior"][apex] and found["dist"][apex] < -BENDING_FLOOR * found["length"][apex]
    # its distance is the one to the chain's node nearest the corner at rest, moved with the state (the cone's shift
    # taken off): a closed form of the node's place, not the search's pieces
    node = int(np.argmin(np.linalg.norm(corners.X - corners.C[apex], axis=1)))
    assert node == corners.pieces[found["piece"][apex]][0 if found["xi"][apex] <= 0.0 else 1]
    moved = corners.X[node] + vec.getValues(corners.nodes[node].astype(PETSc.IntType)) / 1e-3
    moved[1] -= contact.search(vec)["t_c"][0] / 1e-3
    assert found["dist"][apex] == pytest.approx(-np.linalg.norm(corners.C[apex] - moved) * 1e-3, rel=1e-12)
    # the move's diagonal less the rounded corner's offset inside the cone off the cap (off the flank 1.6 % less)
    assert found["dist"][apex] == pytest.approx(-np.sqrt(2) * (2e-5 - rest[apex]), rel=0.02)
    off_the_kink(contact, rng, contact.search(vec)["phi"])
    contact.held.multiplier[:] = 3e4
    step = vec.duplicate()
    step.setArray(1e-10 * rng.standard_normal(step.getLocalSize()))
    slope_error, hessian_error = matches(contact, physics, vec, step)
    assert slope_error <= 1e-6 and hessian_error <= 1e-6
