"""Axisymmetric, torsionless kinematics: the only module that knows the problem is axisymmetric.

With u = (u_r, u_z) on the (r, z) half-plane, the deformation gradient in the order (r, theta, z) is

    F = [[1 + du_r/dr, 0,           du_r/dz    ],
         [0,           1 + u_r / r, 0          ],
         [du_z/dr,     0,           1 + du_z/dz]]

and the volume element is dV = 2 pi r dr dz, so integrals over the half-plane weighted by
:func:`volume_weight` are integrals over the full 360-degree solid (energies in J, forces in N).
Everything downstream (materials, stresses, strains) works on these 3x3 tensors.
"""

from __future__ import annotations

import math
from typing import Any

import ufl

#: Index of each cylindrical component in the 3x3 tensors.
R, THETA, Z = 0, 1, 2


def deformation_gradient(u: Any, x: Any) -> Any:
    """3x3 deformation gradient of an axisymmetric displacement ``u`` at coordinates ``x`` = (r, z)."""
    g = ufl.grad(u)
    return ufl.as_matrix(
        [
            [1 + g[0, 0], 0, g[0, 1]],
            [0, 1 + u[0] / x[0], 0],
            [g[1, 0], 0, 1 + g[1, 1]],
        ]
    )


def volume_weight(x: Any) -> Any:
    """2 pi r: turns dr dz on the half-plane into the volume of the full solid of revolution."""
    return 2 * math.pi * x[0]


def axial(vector: Any) -> Any:
    """The z-component of a (r, z) vector."""
    return vector[1]


def in_plane(tensor3: Any) -> list[Any]:
    """(rr, zz, thetatheta, rz) components of a symmetric 3x3 tensor, the ones an axisymmetric state has."""
    return [tensor3[R, R], tensor3[Z, Z], tensor3[THETA, THETA], tensor3[R, Z]]
