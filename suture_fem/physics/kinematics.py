"""Kinematics: the only module that knows whether the problem is axisymmetric (2-D) or Cartesian (3-D).

With u = (u_r, u_z) on the (r, z) half-plane, the deformation gradient in the order (r, theta, z) is

    F = [[1 + du_r/dr, 0,           du_r/dz    ],
         [0,           1 + u_r / r, 0          ],
         [du_z/dr,     0,           1 + du_z/dz]]

and the volume element is dV = 2 pi r dr dz, so integrals over the half-plane weighted by
:func:`volume_weight` are integrals over the full 360-degree solid (energies in J, forces in N).
Everything downstream (materials, stresses, strains) works on these 3x3 tensors.

In 3-D (``geometry.dimension = 3``, a mesh of geometric dimension 3) u = (u_x, u_y, u_z) with the thread
along y, F = I + grad u, and the mesh is the half model on one side of the symmetry plane z = 0
(:mod:`suture_fem.geometry.gmsh_3d`): the volume weight is 2, so weighted integrals are again those of the
whole solid. Each function tells the two apart by the shape of its argument.
"""

from __future__ import annotations

import math
from typing import Any

import ufl

#: Index of each cylindrical component in the 3x3 tensors.
R, THETA, Z = 0, 1, 2


#: The weight of the 3-D half model: its integrals doubled are those of the whole solid.
HALF_MODEL_WEIGHT = 2.0


def dimension(vector: Any) -> int:
    """2 (axisymmetric, (r, z)) or 3 (Cartesian): the length of a displacement or coordinate vector."""
    return int(ufl.shape(vector)[0])


def deformation_gradient(u: Any, x: Any) -> Any:
    """3x3 deformation gradient of a displacement ``u``: axisymmetric at ``x`` = (r, z), or I + grad u in 3-D."""
    g = ufl.grad(u)
    if dimension(u) == 3:
        return ufl.Identity(3) + g
    return ufl.as_matrix(
        [
            [1 + g[0, 0], 0, g[0, 1]],
            [0, 1 + u[0] / x[0], 0],
            [g[1, 0], 0, 1 + g[1, 1]],
        ]
    )


def volume_weight(x: Any) -> Any:
    """2 pi r: turns dr dz on the half-plane into the volume of the full solid of revolution (3-D: 2, half model)."""
    if dimension(x) == 3:
        return HALF_MODEL_WEIGHT
    return 2 * math.pi * x[0]


def axial(vector: Any) -> Any:
    """The component along the thread: z of a (r, z) vector, y of an (x, y, z) one (index 1 in both)."""
    return vector[1]


def in_plane(tensor3: Any, dim: int = 2) -> list[Any]:
    """The components of a symmetric 3x3 tensor the state has: three normal ones, then the shear ones.

    2-D: (rr, zz, thetatheta, rz), the four an axisymmetric state has; 3-D: (xx, yy, zz, xy, yz, xz).
    """
    if dim == 3:
        t = tensor3
        return [t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[1, 2], t[0, 2]]
    return [tensor3[R, R], tensor3[Z, Z], tensor3[THETA, THETA], tensor3[R, Z]]
