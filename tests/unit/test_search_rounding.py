"""The cones' contact search beside a face far from the origin: its normal is the face's, not a rounded difference."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry.outline import project
from suture_fem.geometry.section import Geometry
from suture_fem.physics.effects.cone_contact import ConeContact
from suture_fem.scene import Scene

MM = 1e-3
EPS = np.finfo(float).eps


def _last_cone() -> tuple[Geometry, object, np.ndarray, np.ndarray]:
    """The paper's fourth cone (apex at 24.29 mm), its flank's top and bottom, and the flank's outward normal."""
    geometry = Geometry.from_section(Scene.builtin("paper").geometry)
    cone = geometry.cones[-1]
    top, base = np.array(cone.points[1]), np.array(cone.points[2])
    normal = np.array([top[1] - base[1], base[0] - top[0]]) / np.linalg.norm(top - base)
    return geometry, cone, top, base, normal


def test_a_point_a_tenth_of_a_micrometre_inside_a_flank_24_mm_up_has_the_flanks_normal_to_round_off():
    """The nearest point is rounded at 24 mm (4e-15 mm); the normal as its offset over a 1e-4 mm distance was
    5e-12 off (and the contact force with it). Beside a face the normal is the face's own."""
    geometry, cone, top, base, normal = _last_cone()
    outline = cone.rounded(1e-3, geometry.r_thread, to_axis=True)
    t = np.linspace(0.1, 0.9, 41)[:, None]
    points = top + t * (base - top) - 1e-4 * normal
    found = project(points, outline)
    assert np.allclose(found.distance, -1e-4, rtol=1e-6)
    assert np.max(np.abs(found.normal - normal)) < 10 * EPS


def _pressed(n: int = 40) -> tuple[ConeContact, PETSc.Vec, np.ndarray]:
    """n tissue nodes 0.1 um inside the fourth cone's flank, everything moved 2.4 mm along the axis; Coulomb."""
    geometry, cone, top, base, normal = _last_cone()
    X = top + np.linspace(0.1, 0.9, n)[:, None] * (base - top) + 1e-4 * normal  # reference: 0.1 um outside
    state = PETSc.Vec().createSeq(2 * n + 1, comm=PETSc.COMM_SELF)
    u = np.zeros(2 * n + 1)
    u[1::2] = u[-1] = 2.4 * MM  # every node and the cone (the last entry) moved along the axis ...
    u[:-1] -= np.tile(2e-4 * MM * normal, n)  # ... and each node 0.2 um inward
    state.setArray(u)
    pairs = {"nodes": np.arange(n), "dofs": np.arange(2 * n).reshape(n, 2), "X": X, "cone": np.zeros(n, dtype=np.int64),
             "weight": np.full(n, 1e-8), "cone_dofs": [np.array([2 * n])], "corner_mm": 0.0,
             "outlines": [cone.rounded(1e-3, geometry.r_thread, to_axis=True)]}
    contact = ConeContact(MPI.COMM_SELF, state, pairs, kappa=1e10, model="coulomb", mu=0.3, slip_m=1e-6)
    contact.bound[:] = 0.3 * 1e10 * 1e-7  # mu p
    return contact, state, u


def test_the_pressed_nodes_residual_is_as_smooth_as_the_rounding_of_their_displacements():
    """Along a random direction of 1e-10 m the contact residual departs from its quadratic fit by its rounding:
    2.2e-15 N with the normal taken from the nearest point's offset, 1.4e-16 N with the face's, within four
    times eps ||H diag|u| || (each unknown rounded by one ulp), 5.0e-17 N."""
    contact, state, u = _pressed()
    assert np.all(contact.pressure() > 0.0)
    hessian = contact._hessian(state)
    of_unknowns = EPS * np.sqrt(np.sum((hessian * np.abs(u[:-1]).reshape(-1, 2)[:, None, :]) ** 2))
    direction = 1e-10 * np.random.default_rng(0).standard_normal(len(u))
    steps = np.linspace(-1.0, 1.0, 21)
    b = PETSc.Vec().createSeq(len(u), comm=PETSc.COMM_SELF)
    residuals = []
    for s in steps:
        state.setArray(u + s * direction)
        b.set(0.0)
        contact.add_residual(state, b)
        residuals.append(b.getArray().copy())
    b.destroy()
    R, fit = np.array(residuals), np.vander(steps, 3)
    noise = float(np.sqrt(np.mean(np.sum((R - fit @ np.linalg.lstsq(fit, R, rcond=None)[0]) ** 2, axis=1))))
    assert 0.0 < noise < 4.0 * of_unknowns
