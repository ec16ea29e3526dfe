"""How big the 3-D half model's mesh will be, estimated before gmsh runs (pure Python).

The 3-D model (:mod:`suture_fem.geometry.gmsh_3d`) uses the 2-D background size h(r, z), revolved, and
at most 2 pi r / ELEMENTS_PER_TURN on a curved surface of radius r (the thread's). A tetrahedron of
size h fills about h^3 / (6 sqrt 2), so the count is about the integral of 6 sqrt(2) / h^3 over the
half solid (dV = pi r dr dz); :data:`CALIBRATION` turns that into gmsh's count. gmsh's tetrahedra grow
away from the thread's finely divided surface more slowly than the size field allows (:data:`GRADATION`),
which is most of a coarse mesh. Rounded rims add the 2-D estimate's fillet refinement revolved (:func:`_fillet_cells`).
The memory of a direct solve grows as the unknowns to the 4/3 (the
fill-in of a 3-D factorisation), of a Krylov solve in proportion to them; both measured on the 3-D
ladders (benchmarks/three_d.py, docs/three-d.md).
"""

from __future__ import annotations

import math

import numpy as np

from suture_fem.geometry.estimate import MeshEstimate, fillet_sizes, fits, size_grid
from suture_fem.geometry.gmsh_3d import ELEMENTS_PER_TURN
from suture_fem.geometry.gmsh_model import FILLET_GRADING, MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.scene.schema import MeshSection, SolverSection

#: gmsh's tetrahedron count over the integral estimate. Fitted on 13 meshes (the cylinder with 1 cone at 5.66,
#: 4, 2.83, 2, 1.41 and 1 times the [mesh] sizes, with 4 cones at 4, 2.83 and 2; the slab with 1 cone at 4 and
#: 2.83, with 4 at 4 and 2; 13,903 to 684,545 tetrahedra): with it each count is 0.89 to 1.09 of the estimate's.
CALIBRATION = 0.62
#: How fast gmsh's tetrahedra grow away from the thread's surface (mm of size per mm of distance) whatever the
#: size field allows: without this bound (and calibrated by 0.7) the estimate was 0.38 of gmsh's count at 5.66
#: times the sizes and 1.15 of it at once the sizes (the same 13 meshes).
GRADATION = 0.4
#: The fillet refinement's tetrahedra over its integral estimate (:func:`_fillet_cells`), times CALIBRATION. Fitted on
#: 4 coarse meshes (1 cone, sizes 0.5 / 0.25 / 3 mm: full cones with fillets of 0.05 mm at 8 and 4 elements along
#: the arc and of 0.1 mm at 8, hollow with 0.05 mm at 8; the fillets' share 21,000 to 91,000 tetrahedra): 1.75 to 2.5
#: of the integral; with 2.1 each mesh's count is 0.86 to 1.13 of the estimate's.
FILLET_FACTOR = 2.1
#: Vertices per tetrahedron of a gmsh mesh (0.18-0.22 on those meshes), and P2 nodes (vertices and
#: edges) per tetrahedron (1.40-1.52): the larger values, so that the estimate errs toward more.
VERTICES_PER_CELL = 0.21
P2_NODES_PER_CELL = 1.5
#: The same in the fillets' refinement (its tetrahedra less the estimate's others), on the meshes of FILLET_FACTOR:
#: 0.169-0.172 vertices per tetrahedron there, and 1.35-1.36 P2 nodes (the full and the hollow cone at 0.05 mm).
FILLET_VERTICES_PER_CELL = 0.17
FILLET_P2_NODES_PER_CELL = 1.35
#: Peak memory of one 3-D solve: a base plus, for a direct (MUMPS) solve, MUMPS_BYTES x unknowns^(4/3).
#: Measured (one process, benchmarks/three_d.py, peak less the base): P1 182 MB with 30,921 dofs, 380 with
#: 55,893, 518 with 65,652, 3,729 with 271,923; P2 546 MB with 63,375, 812 with 84,012, 1,302 with 126,939:
#: 188-212 bytes x dofs^(4/3) (a linear law off by a factor 1.9 between the smallest and the largest).
BASE_GIB = 0.2
MUMPS_BYTES = 215.0
#: A Krylov solve's memory per unknown (GAMG, 337 MB peak with 30,921 dofs: 4.3 kB per dof over the base).
KRYLOV_BYTES_PER_UNKNOWN = 6_000


def estimate_3d(geometry: Geometry, sizes: MeshSizes, degree: int, solver: SolverSection | None = None) -> MeshEstimate:
    """Estimated tetrahedra, unknowns (3 per node) and peak memory of one solve of the 3-D half model.

    The memory is a direct solve's unless ``solver`` resolves to a Krylov method for that many unknowns.
    """
    g = geometry
    n_r, n_z = 400, 800
    r_max = g.r_epidermis if g.slab is None else math.hypot(max(g.slab.x_skin, -g.slab.x_deep), g.slab.half_width)
    rr, zz, h = size_grid(g, sizes, n_r, n_z, r_max)
    curved = 2.0 * math.pi * g.r_thread / ELEMENTS_PER_TURN  # the thread's surface, graded like the suture size
    near = np.maximum(np.abs(rr - g.r_thread), 0.0)
    h = np.minimum(h, curved + np.minimum((sizes.far - curved) / sizes.grading, GRADATION) * near)
    inside = (zz <= g.length) | (rr <= g.r_thread)
    volume = _ring_areas(g, r_max, n_r)[:, None] * (g.z_end / n_z)
    fillet = CALIBRATION * _fillet_cells(g, sizes)
    cells = CALIBRATION * float(np.sum(inside * volume * 6.0 * math.sqrt(2.0) / h**3)) + fillet
    nodes = ((cells - fillet) * (VERTICES_PER_CELL if degree == 1 else P2_NODES_PER_CELL)
             + fillet * (FILLET_VERTICES_PER_CELL if degree == 1 else FILLET_P2_NODES_PER_CELL))
    unknowns = int(3 * nodes)
    krylov = solver is not None and solver.method_for(3, unknowns) != "direct"
    solve = unknowns * KRYLOV_BYTES_PER_UNKNOWN if krylov else MUMPS_BYTES * float(unknowns) ** (4.0 / 3.0)
    return MeshEstimate(int(cells), unknowns, BASE_GIB + solve / 2**30)


def _fillet_cells(g: Geometry, sizes: MeshSizes) -> float:
    """Tetrahedra the fillet refinement adds (the grid is too coarse to see it): the 2-D estimate's, revolved.

    Around each arc (taken as a point at its centre (r_c, y_c): a tube of radius FILLET_GRADING rim revolved by
    pi at r_c) the size grows linearly from ``sizes.fillet(arc length)`` to the rim size; less the rim-size
    tetrahedra the grid integral counts there; times :data:`FILLET_FACTOR`.
    """
    extra = 0.0
    reach = FILLET_GRADING * sizes.rim
    d = (np.arange(200) + 0.5) * reach / 200
    for c, h0 in fillet_sizes(g, sizes):
        h = h0 + (sizes.rim - h0) * d / reach
        tube = math.pi * c[0] * 2.0 * math.pi * d * (reach / 200)  # the ring's volume at distance d, revolved
        extra += float(np.sum(tube * 6.0 * math.sqrt(2.0) * (1 / h**3 - 1 / sizes.rim**3)))
    return FILLET_FACTOR * extra


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


def check_fits_3d(geometry: Geometry, mesh: MeshSection, memory_gib: float | None = None,
                  solver: SolverSection | None = None) -> MeshEstimate:
    """The estimate of a 3-D scene's mesh; SceneError (one line) when its solve cannot fit in memory."""
    return fits(estimate_3d(geometry, MeshSizes.from_section(mesh), mesh.degree, solver), mesh, memory_gib,
                "(mesh.size_* keys, geometry.dimension = 3)", "tetrahedra")
