"""The cones' contact in 3-D: a potential of the meridian place (r, axial) carried to a node's position in space."""

from __future__ import annotations

import numpy as np
import pytest

from suture_fem.physics.effects import cone_frame


def _energy(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A smooth E(r, a), its gradient and Hessian, per row of m (n, 2)."""
    r, a = m[:, 0], m[:, 1]
    e = r**3 * np.sin(a) + 0.5 * a**2 * r
    g = np.stack([3 * r**2 * np.sin(a) + 0.5 * a**2, r**3 * np.cos(a) + a * r], axis=1)
    h = np.stack(
        [
            np.stack([6 * r * np.sin(a), 3 * r**2 * np.cos(a) + a], axis=1),
            np.stack([3 * r**2 * np.cos(a) + a, -(r**3) * np.sin(a) + r], axis=1),
        ],
        axis=1,
    )
    return e, g, h


def test_a_meridian_potential_has_its_3d_gradient_and_hessian_hoop_term_included():
    rng = np.random.default_rng(3)
    p = rng.uniform(-1.0, 1.0, (20, 3)) + np.array([0.0, 0.0, -1.5])  # z < 0, away from the axis
    m, e_r = cone_frame.place(p)
    assert m[:, 0] == pytest.approx(np.hypot(p[:, 0], p[:, 2])) and m[:, 1] == pytest.approx(p[:, 1])
    _, g, h = _energy(m)
    grad = cone_frame.gradient(g, e_r)
    hess = cone_frame.hessian(h, g, e_r, m[:, 0])
    step = 1e-6
    for i in range(3):
        d = np.zeros(3)
        d[i] = step
        plus, minus = _energy(cone_frame.place(p + d)[0]), _energy(cone_frame.place(p - d)[0])
        assert (plus[0] - minus[0]) / (2 * step) == pytest.approx(grad[:, i], rel=1e-8, abs=1e-10)
        g_plus = cone_frame.gradient(plus[1], cone_frame.place(p + d)[1])
        g_minus = cone_frame.gradient(minus[1], cone_frame.place(p - d)[1])
        assert (g_plus - g_minus) / (2 * step) == pytest.approx(hess[:, :, i], rel=1e-6, abs=1e-8)
    hoop = np.stack([-e_r[:, 2], np.zeros(len(p)), e_r[:, 0]], axis=1)  # round the axis: r's curvature alone
    assert np.einsum("ni,nij,nj->n", hoop, hess, hoop) == pytest.approx(g[:, 0] / m[:, 0])


def test_in_2d_the_place_is_the_position_and_the_maps_are_the_identity():
    p = np.array([[0.3, 1.0], [0.5, 2.0]])
    m, e_r = cone_frame.place(p)
    g, h = np.ones((2, 2)), np.ones((2, 2, 2))
    assert m is p and e_r is None
    assert cone_frame.gradient(g, None) is g and cone_frame.hessian(h, g, None, m[:, 0]) is h
