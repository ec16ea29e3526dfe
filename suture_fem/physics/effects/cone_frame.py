"""The cones' contact in 3-D: a tissue node's place in the cones' meridian plane, and derivatives back in space.

The cones' contact (:mod:`~suture_fem.physics.effects.cone_contact`) measures every node against its cone's
outline in the (r, axial) half-plane. In the 3-D half model (the thread along y) a node at p = (x, y, z) sits at
m = (r, y), r = sqrt(x^2 + z^2), in that plane; the outline is revolved about the y axis, so the distance and
the arc length of p are those of m. A potential E(m) of the node's meridian place is then, in space,

    dE/dp = E_r e_r + E_a e_y,
    d2E/dp2 = J^T (d2E/dm2) J + (E_r / r) t t^T,

with e_r = (x, 0, z) / r the unit vector off the axis at p (dr/dp), J = [e_r; e_y] (2 x 3) and t = (-z, 0, x) / r
the hoop direction: the second term is r's own curvature (d2r/dp2 = (I - e_r e_r^T - e_y e_y^T) / r, e_r
turning as p goes round the axis). In 2-D (r, z) the place is the position itself, and these maps are the
identity (each function returns its argument unchanged).
"""

from __future__ import annotations

import numpy as np

from suture_fem.geometry.outline import meridian, radial_directions


def place(positions_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """The meridian places (n, 2) mm of positions (n, dim) mm and their e_r (n, 3); in 2-D (the positions, None)."""
    if positions_mm.shape[1] == 2:
        return positions_mm, None
    return meridian(positions_mm), radial_directions(positions_mm)


def moved(positions_mm: np.ndarray, u_m: np.ndarray, axial_m: np.ndarray, mm: float) -> tuple[np.ndarray, ...]:
    """:func:`place` of the positions moved by u (m) less each row's axial shift (m); ``mm``: a millimetre in m."""
    shift = np.zeros_like(u_m)
    shift[:, 1] = axial_m
    return place(positions_mm + (u_m - shift) / mm)


def gradient(grad_m: np.ndarray, e_r: np.ndarray | None) -> np.ndarray:
    """dE/dp (n, dim) from dE/dm (n, 2) at positions whose e_r :func:`place` gave (None: 2-D, dE/dm itself)."""
    if e_r is None:
        return grad_m
    out = grad_m[:, 0:1] * e_r
    out[:, 1] += grad_m[:, 1]
    return out


def hessian(hess_m: np.ndarray, grad_m: np.ndarray, e_r: np.ndarray | None, r: np.ndarray) -> np.ndarray:
    """d2E/dp2 (n, dim, dim) from d2E/dm2 (n, 2, 2) and dE/dm (n, 2) (None e_r: 2-D, d2E/dm2 itself).

    ``r``: the positions' distances off the axis, in the gradient's length unit (the hoop term divides by it).
    """
    if e_r is None:
        return hess_m
    n = len(grad_m)
    jac = np.zeros((n, 2, 3))
    jac[:, 0, :] = e_r
    jac[:, 1, 1] = 1.0
    out = np.einsum("nai,nab,nbj->nij", jac, hess_m, jac)
    hoop = np.stack([-e_r[:, 2], np.zeros(n), e_r[:, 0]], axis=1)
    out += (grad_m[:, 0] / r)[:, None, None] * hoop[:, :, None] * hoop[:, None, :]
    return out
