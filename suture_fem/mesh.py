"""Mesh: the parametric gmsh model of the half-section, conforming at every suture-tissue interface.

gmsh runs on rank 0 only (OpenCASCADE kernel). The tissue layers, the thread and the cones are
built as separate surfaces and fragmented together, so every interface is shared by both sides and
the suture and tissue are tied through common nodes. Regions and boundaries are classified by the
fragment map and by bounding boxes, never by entity order, and carry the fixed tags below.
The gmsh model is in millimetres; the dolfinx mesh is scaled to metres (SI throughout the solver).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem import compat
from suture_fem.geometry import Geometry
from suture_fem.parallel import on_root

# Cell tags
HYPODERMIS, DERMIS, EPIDERMIS, THREAD, CONE = 1, 2, 3, 4, 5
CELL_TAGS = {"hypodermis": HYPODERMIS, "dermis": DERMIS, "epidermis": EPIDERMIS, "thread": THREAD, "cone": CONE}
TISSUE = (HYPODERMIS, DERMIS, EPIDERMIS)
SUTURE = (THREAD, CONE)
# Facet tags
OUTER, AXIS, PULL_FACE, TISSUE_PULL_FACE, TISSUE_FAR_FACE, THREAD_FAR_FACE, INTERFACE, THREAD_FREE_SIDE = (
    11, 12, 13, 14, 15, 16, 17, 18
)
FACET_TAGS = {
    "outer": OUTER,
    "axis": AXIS,
    "pull_face": PULL_FACE,
    "tissue_pull_face": TISSUE_PULL_FACE,
    "tissue_far_face": TISSUE_FAR_FACE,
    "thread_far_face": THREAD_FAR_FACE,
    "interface": INTERFACE,
    "thread_free_side": THREAD_FREE_SIDE,
}

MM = 1e-3  # metres per millimetre


@dataclass(frozen=True)
class MeshSizes:
    """Target element sizes (mm) after refinement."""

    suture: float
    rim: float
    far: float
    grading: float

    @classmethod
    def from_scene(cls, scene: dict[str, Any]) -> "MeshSizes":
        m = scene["mesh"]
        f = 0.5 ** m["refinement"]
        return cls(m["size_suture_mm"] * f, min(m["size_rim_mm"], m["size_suture_mm"]) * f, m["size_far_mm"] * f,
                   m["grading_mm"])


def build_gmsh_model(geometry: Geometry, sizes: MeshSizes, name: str = "suture") -> None:
    """Build and mesh the half-section in the current gmsh model (call on one rank only)."""
    import gmsh

    gmsh.model.add(name)
    occ = gmsh.model.occ
    g = geometry
    tissue = [
        occ.addRectangle(0.0, 0.0, 0.0, g.r_hypodermis, g.length),
        occ.addRectangle(g.r_hypodermis, 0.0, 0.0, g.r_dermis - g.r_hypodermis, g.length),
        occ.addRectangle(g.r_dermis, 0.0, 0.0, g.r_epidermis - g.r_dermis, g.length),
    ]
    thread = occ.addRectangle(0.0, 0.0, 0.0, g.r_thread, g.z_end)
    cones = [_add_outline(occ, cone.outline) for cone in g.cones]
    inputs = [(2, s) for s in tissue + [thread] + cones]
    _, pieces = occ.fragment(inputs[:1], inputs[1:])
    occ.synchronize()

    owner: dict[int, int] = {}
    for i, region in enumerate([HYPODERMIS, DERMIS, EPIDERMIS]):
        for _, tag in pieces[i]:
            owner.setdefault(tag, region)
    for _, tag in pieces[3]:
        owner[tag] = THREAD  # the thread overrides the hypodermis it was cut from
    for k in range(len(cones)):
        for _, tag in pieces[4 + k]:
            owner[tag] = CONE
    for region, tag in CELL_TAGS.items():
        surfaces = sorted(s for s, r in owner.items() if r == tag)
        if surfaces:
            gmsh.model.addPhysicalGroup(2, surfaces, tag)
            gmsh.model.setPhysicalName(2, tag, region)

    facets = _classify_curves(g, owner)
    for fname, tag in FACET_TAGS.items():
        if facets[tag]:
            gmsh.model.addPhysicalGroup(1, sorted(facets[tag]), tag)
            gmsh.model.setPhysicalName(1, tag, fname)
    _size_fields(g, sizes, facets)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)


def _add_outline(occ: Any, outline: list) -> int:
    """A plane surface bounded by line and arc segments (shared end points are created once)."""
    points: dict[tuple[float, float], int] = {}

    def pt(p: tuple[float, float]) -> int:
        key = (round(p[0], 12), round(p[1], 12))
        if key not in points:
            points[key] = occ.addPoint(p[0], p[1], 0.0)
        return points[key]

    curves = []
    for kind, pts in outline:
        if kind == "line":
            curves.append(occ.addLine(pt(pts[0]), pt(pts[1])))
        else:
            curves.append(occ.addCircleArc(pt(pts[0]), pt(pts[1]), pt(pts[2])))
    return occ.addPlaneSurface([occ.addCurveLoop(curves)])


def _classify_curves(g: Geometry, owner: dict[int, int]) -> dict[int, set[int]]:
    """Boundary and interface curves by bounding box and by the regions on either side."""
    import gmsh

    tol = 1e-7 * max(g.z_end, 1.0)
    out: dict[int, set[int]] = {tag: set() for tag in FACET_TAGS.values()}
    for _, c in gmsh.model.getEntities(1):
        r0, z0, _, r1, z1, _ = gmsh.model.getBoundingBox(1, c)
        up, _ = gmsh.model.getAdjacencies(1, c)
        sides = {owner[s] for s in up}
        if abs(r0 - g.r_epidermis) < tol and abs(r1 - g.r_epidermis) < tol:
            out[OUTER].add(c)
        elif r0 < tol and r1 < tol:
            out[AXIS].add(c)
        elif abs(z0 - g.z_end) < tol and abs(z1 - g.z_end) < tol:
            out[PULL_FACE].add(c)
        elif abs(z0 - g.length) < tol and abs(z1 - g.length) < tol and sides <= set(TISSUE):
            out[TISSUE_PULL_FACE].add(c)
        elif z1 < tol:  # on the far face z = 0
            out[THREAD_FAR_FACE if sides <= set(SUTURE) else TISSUE_FAR_FACE].add(c)
        elif len(up) == 1 and sides <= set(SUTURE) and z0 >= g.length - tol:
            out[THREAD_FREE_SIDE].add(c)
        if sides & set(SUTURE) and sides & set(TISSUE):
            out[INTERFACE].add(c)
    return out


def _size_fields(g: Geometry, sizes: MeshSizes, facets: dict[int, set[int]]) -> None:
    """Fine near the suture surface, finer at the cone corners, coarse far away."""
    import gmsh

    field = gmsh.model.mesh.field
    suture_curves = sorted(facets[INTERFACE] | facets[THREAD_FREE_SIDE] | facets[PULL_FACE])
    sampling = int(min(20000, max(50, math.ceil(2.0 * g.z_end / sizes.suture))))
    d_suture = field.add("Distance")
    field.setNumbers(d_suture, "CurvesList", suture_curves)
    compat.gmsh_set_distance_sampling(d_suture, sampling)
    t_suture = field.add("Threshold")
    field.setNumber(t_suture, "InField", d_suture)
    field.setNumber(t_suture, "SizeMin", sizes.suture)
    field.setNumber(t_suture, "SizeMax", sizes.far)
    field.setNumber(t_suture, "DistMin", 0.0)
    field.setNumber(t_suture, "DistMax", sizes.grading)
    fields = [t_suture]

    corner_points: set[int] = set()
    reach = 1e-6 + max((math.dist(a, b) for c in g.cones for k, seg in c.outline if k == "arc"
                        for a, b in [(seg[0], seg[2])]), default=0.0)
    for r, z in g.corners:
        found = gmsh.model.getEntitiesInBoundingBox(r - reach, z - reach, -1, r + reach, z + reach, 1, 0)
        corner_points.update(tag for _, tag in found)
    if corner_points:
        d_rim = field.add("Distance")
        field.setNumbers(d_rim, "PointsList", sorted(corner_points))
        t_rim = field.add("Threshold")
        field.setNumber(t_rim, "InField", d_rim)
        field.setNumber(t_rim, "SizeMin", sizes.rim)
        field.setNumber(t_rim, "SizeMax", sizes.suture)
        field.setNumber(t_rim, "DistMin", 0.0)
        field.setNumber(t_rim, "DistMax", 4.0 * sizes.suture)
        fields.append(t_rim)
    combined = field.add("Min")
    field.setNumbers(combined, "FieldsList", fields)
    field.setAsBackgroundMesh(combined)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)


@dataclass
class TaggedMesh:
    """A dolfinx mesh (in metres) with its cell and facet tags."""

    mesh: Any
    cell_tags: Any
    facet_tags: Any
    geometry: Geometry
    sizes: MeshSizes


def create_mesh(comm: Any, scene: dict[str, Any]) -> TaggedMesh:
    """Build the mesh of a scene on rank 0 of ``comm`` and distribute it (coordinates in metres)."""
    geometry = Geometry.from_scene(scene)
    sizes = MeshSizes.from_scene(scene)
    if comm.rank == 0:
        with compat.gmsh_session() as gmsh:
            try:
                on_root(comm, "meshing (gmsh)", build_gmsh_model, geometry, sizes)
                mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim=2)
            finally:
                gmsh.model.remove()
    else:
        on_root(comm, "meshing (gmsh)", build_gmsh_model, geometry, sizes)  # rank 0's outcome, on every rank
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(None, comm, 0, gdim=2)
    mesh.geometry.x[:, :2] *= MM
    return TaggedMesh(mesh, cell_tags, facet_tags, geometry, sizes)


def write_msh(scene: dict[str, Any], path: str | Path) -> dict[str, Any]:
    """Write a scene's mesh as a gmsh .msh file (mm) with a JSON record of its parameters beside it."""
    from suture_fem import __version__

    path = Path(path)
    geometry = Geometry.from_scene(scene)
    sizes = MeshSizes.from_scene(scene)
    with compat.gmsh_session() as gmsh:
        try:
            build_gmsh_model(geometry, sizes)
            tmp = path.with_name(path.name + ".part.msh")
            gmsh.write(str(tmp))
            os.replace(tmp, path)
            nodes = len(gmsh.model.mesh.getNodes()[0])
            cells = sum(len(t) for t in gmsh.model.mesh.getElements(2)[1])
        finally:
            gmsh.model.remove()
    record = {
        "suture_fem_version": __version__,
        "units": "mm",
        "nodes": nodes,
        "triangles": int(cells),
        "cell_tags": CELL_TAGS,
        "facet_tags": FACET_TAGS,
        "geometry": geometry.describe(),
        "sizes_mm": sizes.__dict__,
        "scene": {"geometry": scene["geometry"], "mesh": scene["mesh"]},
    }
    from suture_fem.io import write_json

    write_json(path.with_suffix(".json"), record)
    return record


def region_cells(tagged: TaggedMesh, tags: tuple[int, ...] | int) -> np.ndarray:
    """Local cell indices carrying any of the given cell tags."""
    tags = (tags,) if isinstance(tags, int) else tags
    ct = tagged.cell_tags
    return np.sort(ct.indices[np.isin(ct.values, tags)]).astype(np.int32)


def facets(tagged: TaggedMesh, tag: int) -> np.ndarray:
    """Local facet indices carrying a facet tag."""
    ft = tagged.facet_tags
    return ft.indices[ft.values == tag].astype(np.int32)


def describe(tagged: TaggedMesh) -> dict[str, Any]:
    """Global cell count and sizes, JSON-ready."""
    m = tagged.mesh
    n_local = m.topology.index_map(2).size_local
    return {
        "cells": int(m.comm.allreduce(n_local)),
        "sizes_mm": tagged.sizes.__dict__,
        "geometry": tagged.geometry.describe(),
    }

