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
    r_max = g.r_epidermis if g.slab is None else math.hypot(max(g.slab.x_skin, -g.slab.x_deep), g.slab.half_width)
    rr, zz, h = size_grid(g, sizes, n_r, n_z, r_max)
    curved = 2.0 * math.pi * g.r_thread / ELEMENTS_PER_TURN  # the thread's surface, graded like the suture size
    near = np.maximum(np.abs(rr - g.r_thread), 0.0)
    h = np.minimum(h, curved + (sizes.far - curved) * np.minimum(near / sizes.grading, 1.0))
    inside = (zz <= g.length) | (rr <= g.r_thread)
    volume = _ring_areas(g, r_max, n_r)[:, None] * (g.z_end / n_z)
    cells = CALIBRATION * float(np.sum(inside * volume * 6.0 * math.sqrt(2.0) / h**3))
    nodes = cells * (VERTICES_PER_CELL if degree == 1 else P2_NODES_PER_CELL)
    unknowns = int(3 * nodes)
    return MeshEstimate(int(cells), unknowns, BASE_GIB + unknowns * BYTES_PER_UNKNOWN / 2**30)


def _ring_areas(g: Geometry, r_max: float, n_r: int) -> np.ndarray:
    """The half model's cross-section area (mm^2) between radii r and r + dr from the thread, per grid ring.

    The cylinder's half ring is pi r dr; the slab's is the part of its rectangle x_deep <= x <= x_skin,
    -half_width <= z <= 0 at that distance, counted on a fine grid of the rectangle.
    """
    dr = r_max / n_r
    if g.slab is None:
        return math.pi * (np.arange(n_r) + 0.5) * dr * dr
    s, n = g.slab, 800
    x = s.x_deep + (np.arange(n) + 0.5) * (s.x_skin - s.x_deep) / n
    z = (np.arange(n) + 0.5) * s.half_width / n
    r = np.hypot(x[:, None], z[None, :]).ravel()
    cell = (s.x_skin - s.x_deep) * s.half_width / n**2
    return np.histogram(r, bins=n_r, range=(0.0, r_max))[0] * cell


def check_fits_3d(geometry: Geometry, mesh: MeshSection, memory_gib: float | None = None) -> MeshEstimate:
    """The estimate of a 3-D scene's mesh; SceneError (one line) when its solve cannot fit in memory."""
    return fits(estimate_3d(geometry, MeshSizes.from_section(mesh), mesh.degree), mesh, memory_gib,
                "(mesh.size_* keys, geometry.dimension = 3)", "tetrahedra")
