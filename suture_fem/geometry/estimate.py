"""How big a mesh will be, estimated before gmsh runs (pure Python), so a scene that cannot fit is refused.

The background size field of :mod:`suture_fem.geometry.gmsh_model` is ``h = suture`` on the suture's
surface, growing linearly to ``far`` over ``grading`` mm, and ``rim`` within ``4 suture`` of a cone
corner, and a size growing from ``sizes.fillet`` on each fillet arc back to ``rim``.
A triangle of size h covers about sqrt(3)/4 h^2, so the number of triangles is about the
integral of 4 / (sqrt(3) h^2) over the half-section, computed here on a grid. The constant that turns
that into gmsh's count was measured on the paper scene (:data:`CALIBRATION`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from suture_fem.geometry.gmsh_model import FILLET_GRADING, MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.scene.schema import MeshSection
from suture_fem.support.errors import SceneError

#: gmsh's triangle count over the integral estimate: gmsh meshes the paper scene with 12,665 triangles
#: at refinement 0 and 43,258 at refinement 1, and its one-cone variant with 3,899; the integral alone
#: gives 0.88, 0.96 and 0.88 of those.
CALIBRATION = 1.1
#: Peak resident memory of one solve: a base (Python, dolfinx, the compiled forms) plus a share per
#: unknown (Jacobian, MUMPS LU factors with PORD fill-in, work vectors). Measured on the paper scene at
#: degree 2 (one process): 350 MB with 51,556 dofs (refinement 0), 869 MB with 174,762 (refinement 1),
#: i.e. 4.2 kB per dof on a 133 MB base; the factor below leaves room for the fill-in's growth.
BASE_GIB = 0.2
BYTES_PER_UNKNOWN = 6_000


@dataclass(frozen=True)
class MeshEstimate:
    """Estimated size of a scene's mesh and solve."""

    cells: int
    unknowns: int
    memory_gib: float

    def describe(self) -> str:
        """One line for the log."""
        return f"about {self.cells:,} cells, {self.unknowns:,} unknowns, {self.memory_gib:.2g} GiB"


def estimate(geometry: Geometry, sizes: MeshSizes, degree: int) -> MeshEstimate:
    """Estimated triangles, unknowns (2 per P1 node or P2 node) and peak memory of one solve."""
    g = geometry
    n_r, n_z = 400, 800
    rr, zz, h = size_grid(g, sizes, n_r, n_z)
    inside = (zz <= g.length) | (rr <= g.r_thread)  # the free thread end is the only part above the tissue
    cell_area = (g.r_epidermis / n_r) * (g.z_end / n_z)
    cells = CALIBRATION * float(np.sum(inside * cell_area * 4.0 / (math.sqrt(3.0) * h**2)) + _fillet_cells(g, sizes))
    nodes = cells / 2.0 * (1 if degree == 1 else 4)  # a triangulation has about twice as many cells as vertices
    unknowns = int(2 * nodes)
    return MeshEstimate(int(cells), unknowns, BASE_GIB + unknowns * BYTES_PER_UNKNOWN / 2**30)


def size_grid(g: Geometry, sizes: MeshSizes, n_r: int, n_z: int,
              r_max: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, z, h): the background size field on the cell centres of an n_r x n_z grid over the half-section (mm).

    The grid spans r up to ``r_max`` (default the epidermis' outer radius).
    """
    r = (np.arange(n_r) + 0.5) * (g.r_epidermis if r_max is None else r_max) / n_r
    z = (np.arange(n_z) + 0.5) * g.z_end / n_z
    rr, zz = np.meshgrid(r, z, indexing="ij")
    surface = np.full_like(zz, g.r_thread)
    for cone in g.cones:  # the cone's outer radius where it stands (its outline's widest point, conservatively)
        lo, hi = min(cone.base_z, cone.apex_z), max(cone.base_z, cone.apex_z)
        widest = max(p[0] for kind, seg in cone.outline for p in seg)
        surface = np.where((zz >= lo) & (zz <= hi), np.maximum(surface, widest), surface)
    distance = np.maximum(rr - surface, 0.0)
    h = sizes.suture + (sizes.far - sizes.suture) * np.minimum(distance / sizes.grading, 1.0)
    for rc, zc in g.corners:
        near = np.hypot(rr - rc, zz - zc)
        rim = sizes.rim + (sizes.suture - sizes.rim) * np.minimum(near / (4.0 * sizes.suture), 1.0)
        h = np.minimum(h, rim)
    return rr, zz, h


def _fillet_cells(g: Geometry, sizes: MeshSizes) -> float:
    """Triangles the fillet refinement adds (the grid is too coarse to see it).

    Around each arc (taken as a point: a disc of radius FILLET_GRADING rim) the size grows linearly from
    ``sizes.fillet(arc length)`` to the rim size; less the rim-size triangles the grid integral counts there.
    """
    extra = 0.0
    reach = FILLET_GRADING * sizes.rim
    d = (np.arange(200) + 0.5) * reach / 200
    for _, h0 in fillet_sizes(g, sizes):
        h = h0 + (sizes.rim - h0) * d / reach
        extra += float(np.sum(2 * np.pi * d * (reach / 200) * 4.0 / math.sqrt(3.0) * (1 / h**2 - 1 / sizes.rim**2)))
    return extra


def fillet_sizes(g: Geometry, sizes: MeshSizes) -> Iterator[tuple[tuple[float, float], float]]:
    """Each fillet arc of the cones: its centre (r, z) and the mesh size on it (``sizes.fillet`` of its length)."""
    for cone in g.cones:
        for _, c, _, _, length in cone.arcs():
            yield c, sizes.fillet(length)


def machine_memory_gib() -> float:
    """Physical memory of this machine (GiB)."""
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 2**30


#: Largest share of the machine's memory one solve may be estimated to need.
MEMORY_SHARE = 0.8


def check_fits(geometry: Geometry, mesh: MeshSection, memory_gib: float | None = None) -> MeshEstimate:
    """The estimate of a scene's mesh; SceneError (one line) when its solve cannot fit in memory."""
    return fits(estimate(geometry, MeshSizes.from_section(mesh), mesh.degree), mesh, memory_gib,
                "(with the mesh.size_* keys)", "cells")


def fits(found: MeshEstimate, mesh: MeshSection, memory_gib: float | None, keys: str, cells: str) -> MeshEstimate:
    """``found``, or SceneError (one line naming ``mesh.refinement`` and ``keys``) when it cannot fit in memory."""
    available = machine_memory_gib() if memory_gib is None else memory_gib
    if found.memory_gib > MEMORY_SHARE * available:
        raise SceneError(
            f"scene key mesh.refinement = {mesh.refinement} {keys}: the mesh would have about {found.cells:,} "
            f"{cells} and {found.unknowns:,} unknowns, needing about {found.memory_gib:,.0f} GiB; "
            f"this machine has {available:.0f} GiB (allowed: an estimate up to {MEMORY_SHARE:.0%} of it)"
        )
    return found
