"""The 3-D cylinder model: the axisymmetric half-section revolved half a turn about the thread, meshed by gmsh.

Every piece of the 2-D model (the three tissue layers, the thread, each cone's outline) is revolved by
pi about the thread's axis (for the slab, ``geometry.slab``, the suture's pieces only: its layers are boxes,
:mod:`suture_fem.geometry.slab`) with the OpenCASCADE kernel and the solids are fragmented together, so the
suture and the tissue share their interface nodes (tied) as in 2-D. The result is a half model:
gmsh's (x, y, z) with the thread along y (the 2-D model's z, so the axial component keeps index 1),
the solid in z <= 0 and the symmetry plane z = 0 (facet tag ``symmetry``). Regions and boundaries are
classified as in 2-D: each revolved face is the image of a 2-D curve, so its sampled (r, y) extent,
r = sqrt(x^2 + z^2), and the regions on its two sides say what it is. Sizes: the 2-D model's
thresholds on gmsh Distance fields to the suture's surfaces and to the cone rims' circles. Lengths in
millimetres; call on one rank only.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from suture_fem.geometry.curved import straighten_folded_gmsh
from suture_fem.geometry.gmsh_model import (
    FILLET_GRADING,
    MeshSizes,
    add_groups,
    owners,
    section_surfaces,
    split_interfaces,
    suture_surfaces,
)
from suture_fem.geometry.regions import FACET_TAGS, SUTURE, TISSUE, Facet
from suture_fem.geometry.section import Geometry
from suture_fem.geometry.slab import Slab
from suture_fem.support import compat

log = logging.getLogger("suture_fem")

#: The revolution's angle: half a turn (the symmetry plane z = 0 closes the half model).
ANGLE = math.pi
#: Elements per full turn of a curved surface (gmsh's curvature sizing): 6 on the thread's half circle.
ELEMENTS_PER_TURN = 12
#: Parametric samples per direction when a face's (r, y) extent is measured.
SAMPLES = 7


def build_gmsh_model_3d(geometry: Geometry, sizes: MeshSizes, name: str = "suture3d", split_thread: bool = False,
                        split_cones: bool = False, geometry_degree: int = 1) -> None:
    """Build and mesh the 3-D half model of the cylinder, or of the slab, in the current gmsh model (one rank only).

    ``geometry_degree`` 2 makes the tetrahedra quadratic (``mesh.geometry_degree``): gmsh places their mid-edge nodes
    on the model's surfaces, so the thread's and the layers' cylinders, the cones and the rims' tori are curved,
    not faceted; a cell the curving folds (a sliver with its four vertices on one surface) keeps straight edges
    (:func:`~suture_fem.geometry.curved.straighten_folded_gmsh`). Unlike 2-D, where only the fillet arcs are curved,
    every 3-D model has curved surfaces.

    The slab (``geometry.slab``): the three layers as boxes, the suture's pieces revolved as for the cylinder.
    ``split_thread`` gives the tissue its own nodes along the bare thread (the faces tagged ``track``),
    ``split_cones`` on the cones' surfaces, as in 2-D (:func:`~suture_fem.geometry.gmsh_model.split_interfaces`).
    """
    import gmsh

    gmsh.model.add(name)
    occ = gmsh.model.occ
    g = geometry
    if g.slab is None:
        solids = [revolved(occ, s) for s in section_surfaces(occ, g)]
        shape_face = _cylinder_face(g)
    else:
        layers = [[(3, occ.addBox(lo, 0.0, -g.slab.half_width, hi - lo, g.length, g.slab.half_width))]
                  for lo, hi in g.slab.layers]
        solids = [*layers, *[revolved(occ, s) for s in suture_surfaces(occ, g)]]
        shape_face = _slab_face(g.slab, g.z_end)
    _, pieces = occ.fragment(solids[0], [dt for group in solids[1:] for dt in group])
    occ.synchronize()
    owner = owners(pieces, len(g.cones))
    faces = classify_faces(g, owner, shape_face)
    add_groups(3, owner, faces)
    _size_fields(g, sizes, faces)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(3)
    if geometry_degree == 2:
        gmsh.model.mesh.setOrder(2)  # mid-edge nodes on the model's surfaces
        straightened = straighten_folded_gmsh()
        if straightened:
            log.info("meshing: %d quadratic tetrahedra folded when curved; their edges are straight", straightened)
    if split_thread or split_cones:
        split_interfaces(owner, faces, thread=split_thread, cones=split_cones, dim=3)


def revolved(occ: Any, surface: int) -> list[tuple[int, int]]:
    """The solid a section surface sweeps when revolved by :data:`ANGLE` about the thread's axis (y)."""
    return [(d, t) for d, t in occ.revolve([(2, surface)], 0, 0, 0, 0, 1, 0, ANGLE) if d == 3]


def samples(dim: int, tag: int) -> np.ndarray:
    """Points (x, y, z) of an entity, sampled on a grid of its parametrisation (mm), one row each."""
    import gmsh

    lo, hi = gmsh.model.getParametrizationBounds(dim, tag)
    axes = [np.linspace(a, b, SAMPLES) for a, b in zip(lo, hi)]
    params = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1)
    return np.asarray(gmsh.model.getValue(dim, tag, params.tolist())).reshape(-1, 3)


def extent(dim: int, tag: int) -> tuple[float, float, float, float, float]:
    """(r_min, r_max, y_min, y_max, |z|_max) of an entity, sampled on its parametrisation (mm)."""
    xyz = samples(dim, tag)
    r = np.hypot(xyz[:, 0], xyz[:, 2])
    y = xyz[:, 1]
    return float(r.min()), float(r.max()), float(y.min()), float(y.max()), float(np.abs(xyz[:, 2]).max())


#: A rule for the faces that only one tissue shape has: sampled points (x, y, z) -> their facet tag, or None.
ShapeFace = Callable[[np.ndarray], "Facet | None"]


def _cylinder_face(g: Geometry) -> ShapeFace:
    """The cylinder's outer epidermis surface r = r_epidermis: fixed (``outer``)."""
    tol = 1e-6 * max(g.z_end, 1.0)

    def face(xyz: np.ndarray) -> Facet | None:
        return Facet.OUTER if np.all(np.abs(np.hypot(xyz[:, 0], xyz[:, 2]) - g.r_epidermis) < tol) else None

    return face


def _slab_face(slab: Slab, z_end: float) -> ShapeFace:
    """The slab's skin x = x_skin (``skin``, free), and its deep face and lateral face (``outer``, fixed)."""
    tol = 1e-6 * max(z_end, 1.0)

    def face(xyz: np.ndarray) -> Facet | None:
        if np.all(np.abs(xyz[:, 0] - slab.x_skin) < tol):
            return Facet.SKIN
        if np.all(np.abs(xyz[:, 0] - slab.x_deep) < tol) or np.all(np.abs(xyz[:, 2] + slab.half_width) < tol):
            return Facet.OUTER
        return None

    return face


def classify_faces(g: Geometry, owner: dict[int, int], shape_face: ShapeFace) -> dict[int, set[int]]:
    """Boundary and interface faces: the symmetry plane, the shape's own faces, then the 2-D rules on (r, y).

    ``shape_face`` finds the faces of the tissue shape (the cylinder's outer surface, the slab's skin and fixed
    faces); the rest by the 2-D model's rules on each face's sampled (r, y) extent and the regions on its sides.
    """
    import gmsh

    tol = 1e-6 * max(g.z_end, 1.0)
    out: dict[int, set[int]] = {tag: set() for tag in FACET_TAGS.values()}
    for _, s in gmsh.model.getEntities(2):
        xyz = samples(2, s)
        y0, y1, zmax = float(xyz[:, 1].min()), float(xyz[:, 1].max()), float(np.abs(xyz[:, 2]).max())
        up, _ = gmsh.model.getAdjacencies(2, s)
        sides = {owner[v] for v in up}
        own = shape_face(xyz)
        if zmax < tol and len(up) == 1:
            out[Facet.SYMMETRY].add(s)
        elif own is not None:
            out[own].add(s)
        elif abs(y0 - g.z_end) < tol and abs(y1 - g.z_end) < tol:
            out[Facet.PULL_FACE].add(s)
        elif abs(y0 - g.length) < tol and abs(y1 - g.length) < tol and sides <= set(TISSUE):
            out[Facet.TISSUE_PULL_FACE].add(s)
        elif y1 < tol:
            out[Facet.THREAD_FAR_FACE if sides <= set(SUTURE) else Facet.TISSUE_FAR_FACE].add(s)
        elif len(up) == 1 and sides <= set(SUTURE) and y0 >= g.length - tol:
            out[Facet.THREAD_FREE_SIDE].add(s)
        if sides & set(SUTURE) and sides & set(TISSUE):
            out[Facet.INTERFACE].add(s)
    return out


def rim_circles(g: Geometry) -> list[int]:
    """The curves that are rim circles: a sharp cone corner, or either end of a fillet arc, revolved.

    Every sample of such a curve lies at one (r, y) of the section: a corner's, or a fillet arc's end point's
    (the 2-D model sizes the points within an arc's chord of a corner, which are these ends).
    """
    import gmsh

    tol = 1e-6 * max(g.z_end, 1.0)
    rims = [*g.corners, *(p for cone in g.cones for a, _, b, _, _ in cone.arcs() for p in (a, b))]
    found = []
    for _, c in gmsh.model.getEntities(1):
        r0, r1, y0, y1, _ = extent(1, c)
        if any(abs(r0 - rc) < tol and abs(r1 - rc) < tol and abs(y0 - zc) < tol and abs(y1 - zc) < tol
               for rc, zc in rims):
            found.append(c)
    return found


def fillet_faces(g: Geometry) -> list[tuple[int, float, float]]:
    """(face, the arc's length, its largest r; mm) of every fillet arc revolved: each sample on the arc's circle."""
    import gmsh

    tol = 1e-6 * max(g.z_end, 1.0)
    out = []
    for a, centre, b, radius, length in (arc for cone in g.cones for arc in cone.arcs()):
        for _, s in gmsh.model.getEntities(2):
            xyz = samples(2, s)
            d = np.hypot(np.hypot(xyz[:, 0], xyz[:, 2]) - centre[0], xyz[:, 1] - centre[1])
            if np.all(np.abs(d - radius) < tol):
                out.append((s, length, max(a[0], b[0])))
    return out


def _threshold(field: Any, source: int, size_min: float, size_max: float, dist_max: float) -> int:
    t = field.add("Threshold")
    field.setNumber(t, "InField", source)
    field.setNumber(t, "SizeMin", size_min)
    field.setNumber(t, "SizeMax", size_max)
    field.setNumber(t, "DistMin", 0.0)
    field.setNumber(t, "DistMax", dist_max)
    return t


def _size_fields(g: Geometry, sizes: MeshSizes, faces: dict[int, set[int]]) -> None:
    """The 2-D thresholds: ``suture`` on the suture's surface growing to ``far``, ``rim`` at the cone rims."""
    import gmsh

    field = gmsh.model.mesh.field
    suture_faces = sorted(faces[Facet.INTERFACE] | faces[Facet.THREAD_FREE_SIDE] | faces[Facet.PULL_FACE])
    d_suture = field.add("Distance")
    compat.gmsh_distance_surfaces(d_suture, suture_faces)
    # points per parametric direction: the thread's length at half the suture size, within bounds
    compat.gmsh_set_distance_sampling(d_suture, int(min(400, max(40, math.ceil(2.0 * g.z_end / sizes.suture)))))
    fields = [_threshold(field, d_suture, sizes.suture, sizes.far, sizes.grading)]
    circles = rim_circles(g)
    if circles:
        d_rim = field.add("Distance")
        field.setNumbers(d_rim, "CurvesList", circles)
        compat.gmsh_set_distance_sampling(d_rim, int(min(2000, max(40, math.ceil(4.0 * g.r_hypodermis / sizes.rim)))))
        fields.append(_threshold(field, d_rim, sizes.rim, sizes.suture, 4.0 * sizes.suture))
    fields += _fillet_fields(g, sizes)
    combined = field.add("Min")
    field.setNumbers(combined, "FieldsList", fields)
    field.setAsBackgroundMesh(combined)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints"):
        gmsh.option.setNumber(option, 0)
    # the thread (r = 0.125 mm) is thinner than the suture size: its half circle still gets elements
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", ELEMENTS_PER_TURN)


def _fillet_fields(g: Geometry, sizes: MeshSizes) -> list[int]:
    """The 2-D fillet sizing on each revolved arc: ``sizes.fillet(length)`` on it, graded to the rim size nearby."""
    import gmsh

    field = gmsh.model.mesh.field
    out = []
    for face, length, r_max in fillet_faces(g):
        h = sizes.fillet(length)
        d = field.add("Distance")
        compat.gmsh_distance_surfaces(d, [face])
        # points per parametric direction: the half circle's length at half the arc's size
        compat.gmsh_set_distance_sampling(d, int(min(1000, max(40, math.ceil(2.0 * math.pi * r_max / h)))))
        t = _threshold(field, d, h, sizes.rim, FILLET_GRADING * sizes.rim)
        field.setNumber(t, "StopAtDistMax", 1)  # no constraint beyond: the other fields size the rest
        out.append(t)
    return out
