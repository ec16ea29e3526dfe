"""How big the 3-D half model's mesh will be, estimated before gmsh runs (pure Python).

The 3-D model (:mod:`suture_fem.geometry.gmsh_3d`) uses the 2-D background size h(r, z), revolved, and
at most 2 pi r / ELEMENTS_PER_TURN on a curved surface of radius r (the thread's). A tetrahedron of
size h fills about h^3 / (6 sqrt 2), so the count is about the integral of 6 sqrt(2) / h^3 over the
half solid (dV = pi r dr dz); :data:`CALIBRATION` turns that into gmsh's count, and the memory per
unknown was measured on the 3-D ladder (benchmarks/three_d.py).
"""

from __future__ import annotations

import math

import numpy as np

from suture_fem.geometry.estimate import MeshEstimate, fits, size_grid
from suture_fem.geometry.gmsh_3d import ELEMENTS_PER_TURN
from suture_fem.geometry.gmsh_model import MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.scene.schema import MeshSection

#: gmsh's tetrahedron count over the integral estimate: gmsh gives 51,431 and 275,510 tetrahedra on the 1-cone
#: hollow scene at twice and once the default sizes, and 168,066 at 4 cones, twice: 0.76, 0.60, 0.76 of the integral.
CALIBRATION = 0.7
#: Vertices per tetrahedron of a gmsh mesh, and P2 nodes (vertices and edges) per tetrahedron.
VERTICES_PER_CELL = 0.2
P2_NODES_PER_CELL = 1.4
#: Peak memory of one 3-D solve: a base plus a share per unknown. Measured (P1, MUMPS, one process,
#: benchmarks/three_d.py): 387 MB with 30,921 dofs, 585 MB with 55,893, 723 MB with 65,652, i.e. 6.4, 7.1 and
#: 8.1 kB per dof over the 2-D runs' 190 MB base; MUMPS' 3-D fill-in grows faster than the dofs, hence the margin.
BASE_GIB = 0.2
BYTES_PER_UNKNOWN = 12_000


def estimate_3d(geometry: Geometry, sizes: MeshSizes, degree: int) -> MeshEstimate:
    """Estimated tetrahedra, unknowns (3 per node) and peak memory of one solve of the 3-D half model."""
    g = geometry
    n_r, n_z = 400, 800
    rr, zz, h = size_grid(g, sizes, n_r, n_z)
    curved = 2.0 * math.pi * g.r_thread / ELEMENTS_PER_TURN  # the thread's surface, graded like the suture size
    near = np.maximum(np.abs(rr - g.r_thread), 0.0)
    h = np.minimum(h, curved + (sizes.far - curved) * np.minimum(near / sizes.grading, 1.0))
    inside = (zz <= g.length) | (rr <= g.r_thread)
    volume = math.pi * rr * (g.r_epidermis / n_r) * (g.z_end / n_z)
    cells = CALIBRATION * float(np.sum(inside * volume * 6.0 * math.sqrt(2.0) / h**3))
    nodes = cells * (VERTICES_PER_CELL if degree == 1 else P2_NODES_PER_CELL)
    unknowns = int(3 * nodes)
    return MeshEstimate(int(cells), unknowns, BASE_GIB + unknowns * BYTES_PER_UNKNOWN / 2**30)


def check_fits_3d(geometry: Geometry, mesh: MeshSection, memory_gib: float | None = None) -> MeshEstimate:
    """The estimate of a 3-D scene's mesh; SceneError (one line) when its solve cannot fit in memory."""
    return fits(estimate_3d(geometry, MeshSizes.from_section(mesh), mesh.degree), mesh, memory_gib,
                "(mesh.size_* keys, geometry.dimension = 3)", "tetrahedra")
