"""The 3-D half model's supports: the outer surface fixed, the symmetry plane through the thread.

In 3-D (``geometry.dimension = 3``; :mod:`suture_fem.geometry.gmsh_3d`) the mesh is the half of the
cylinder on one side of the plane z = 0, which contains the thread's axis (y). The loading and the
geometry are symmetric about that plane, so the whole solid's solution has u_z = 0 on it and the half
model holds it there; the rest is as in 2-D: u = 0 on the outer epidermis surface, free elsewhere.
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import numpy as np
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions

#: The component normal to the symmetry plane z = 0.
NORMAL = 2


def supports_3d(tagged: meshmod.TaggedMesh, W_u: Any) -> tuple[list[Any], np.ndarray]:
    """The supports u = 0 on the outer surface and u_z = 0 on the symmetry plane; the outer axial (u_y) dofs."""
    mesh = tagged.mesh
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    outer = meshmod.facets(tagged, regions.Facet.OUTER)
    plane = meshmod.facets(tagged, regions.Facet.SYMMETRY)
    zero = PETSc.ScalarType(0.0)

    def fixed(component: int, facets: np.ndarray) -> Any:
        sub = W_u.sub(component)
        return dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(sub, fdim, facets), sub)

    bcs = [fixed(c, outer) for c in range(3)] + [fixed(NORMAL, plane)]
    outer_axial = dolfinx.fem.locate_dofs_topological(W_u.sub(1), fdim, outer)
    return bcs, np.asarray(outer_axial, dtype=np.int32)
