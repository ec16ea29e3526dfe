"""The cones' wall guard on a hand-made pair set: a node's depth is the deepest point of its way, not its end."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry.section import Geometry
from suture_fem.physics.effects.cone_contact import DEPTH_FRACTION, ConeContact
from suture_fem.scene import Scene

MM = 1e-3


def _contact() -> tuple[ConeContact, PETSc.Vec]:
    """One paper cone, a tissue node on its apex cap's face (r = 0.14 mm); the state's last entry: the cone's u_z."""
    scene = Scene.builtin("paper").with_values({"geometry.cones": 1})
    geometry = Geometry.from_section(scene.geometry)
    cone, wall = geometry.cones[0], scene.geometry.cone_wall_mm
    X = np.array([[0.14, cone.apex_z]])
    n = len(X)
    state = PETSc.Vec().createSeq(2 * n + 1, comm=PETSc.COMM_SELF)
    state.set(0.0)
    pairs = {"nodes": np.arange(n), "dofs": np.arange(2 * n).reshape(n, 2), "X": X, "cone": np.zeros(n, dtype=np.int64),
             "weight": np.full(n, 1e-8), "cone_dofs": [np.array([2 * n])], "corner_mm": 0.0,
             "outlines": [cone.rounded(1e-3, geometry.r_thread, to_axis=True)]}
    contact = ConeContact(MPI.COMM_SELF, state, pairs, kappa=1e10, model="frictionless", mu=0.0, slip_m=1e-6,
                          wall_m=wall * MM)
    assert contact.depth_limit == pytest.approx(DEPTH_FRACTION * wall * MM)
    return contact, state


def test_a_node_carried_through_the_cap_in_one_step_is_refused_though_it_ends_outside():
    """A node on the apex cap's face moved straight through the 0.13 mm cap ends in the cavity, 0.02 mm below the
    cap's inner face and outside the cone: refused, half the wall deep, for the way it went. From where it ended,
    taken as the next trial's start, a short move on in the cavity is admissible (the way no longer crosses)."""
    contact, state = _contact()
    apex = contact.X[0, 1]
    wall = 0.13
    state.setValues([1], [-(wall + 0.02) * MM])  # through the cap, into the cavity below it
    depth, limit, where, cone = contact.deepest()
    assert -contact.search(state)["phi"][0] < 0.0  # its end alone reads outside the cone
    assert depth == pytest.approx(0.5 * wall * MM, rel=1e-6) and depth > limit
    assert where == pytest.approx([0.14, apex]) and cone == 0
    contact.anchor()
    state.setValues([1], [-(wall + 0.03) * MM])
    assert contact.deepest()[0] == 0.0


def test_a_node_pressed_into_the_cap_by_less_than_the_limit_is_admissible_and_deeper_is_not():
    contact, state = _contact()
    limit = contact.depth_limit
    state.setValues([1], [-0.9 * limit])
    assert contact.deepest()[0] == pytest.approx(0.9 * limit, rel=1e-9)
    state.setValues([1], [-1.1 * limit])
    assert contact.deepest()[0] == pytest.approx(1.1 * limit, rel=1e-9)
