"""The parametric gmsh model of the half-section, conforming at every suture-tissue interface.

The tissue layers, the thread and the cones are built as separate surfaces and fragmented together,
so every interface is shared by both sides and the suture and tissue are tied through common nodes.
Regions and boundaries are classified by the fragment map and by bounding boxes, never by entity
order, and carry the fixed tags of :mod:`suture_fem.geometry.regions`. Lengths are in millimetres.
Call on one rank only (:mod:`suture_fem.geometry.mesh` distributes the result).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from suture_fem.geometry.regions import CELL_TAGS, FACET_TAGS, SUTURE, TISSUE, Cell, Facet
from suture_fem.geometry.section import Geometry
from suture_fem.scene.schema import MeshSection
from suture_fem.support import compat


@dataclass(frozen=True)
class MeshSizes:
    """Target element sizes (mm) after refinement."""

    suture: float
    rim: float
    far: float
    grading: float
    fillet_elements: int = 8

    @classmethod
    def from_section(cls, m: MeshSection) -> MeshSizes:
        """Sizes of a scene's ``[mesh]`` section: each halved ``refinement`` times (the rim never coarser).

        The elements along a fillet arc double with every refinement.
        """
        f = 0.5**m.refinement
        return cls(m.size_suture_mm * f, min(m.size_rim_mm, m.size_suture_mm) * f, m.size_far_mm * f, m.grading_mm,
                   m.fillet_elements * 2**m.refinement)

    def fillet(self, arc_length: float) -> float:
        """Element size on a fillet arc of that length: ``fillet_elements`` along it, never coarser than the rim."""
        return min(arc_length / self.fillet_elements, self.rim)


#: A fillet's refinement grades back to the rim size over this many rim sizes from the arc.
FILLET_GRADING = 3.0


def build_gmsh_model(geometry: Geometry, sizes: MeshSizes, name: str = "suture", geometry_degree: int = 1,
                     split_thread: bool = False, split_cones: bool = False) -> None:
    """Build and mesh the half-section in the current gmsh model (call on one rank only).

    ``geometry_degree`` 2 makes the cells quadratic when the section has fillet arcs (their mid-side
    nodes on the arcs; ``mesh.geometry_degree``); without arcs the mesh stays straight-sided.
    ``split_thread`` gives the tissue its own nodes along the bare thread, ``split_cones`` on the cones'
    surfaces (:func:`split_interfaces`).
    """
    import gmsh

    gmsh.model.add(name)
    occ = gmsh.model.occ
    g = geometry
    inputs = [(2, s) for s in section_surfaces(occ, g)]
    _, pieces = occ.fragment(inputs[:1], inputs[1:])
    occ.synchronize()
    owner = owners(pieces, len(g.cones))
    facets = _classify_curves(g, owner)
    add_groups(2, owner, facets)
    _size_fields(g, sizes, facets)
    gmsh.option.setNumber("Mesh.Algorithm", 6)
    gmsh.model.mesh.generate(2)
    if geometry_degree == 2 and fillet_arcs():
        gmsh.model.mesh.setOrder(2)  # mid-side nodes on the model's curves: the arcs' nodes lie on the arcs
    if split_thread or split_cones:
        split_interfaces(owner, facets, thread=split_thread, cones=split_cones)


def section_surfaces(occ: Any, g: Geometry) -> list[int]:
    """The half-section's pieces as OCC surfaces: the three tissue layers, the thread, each cone (this order)."""
    return [
        occ.addRectangle(0.0, 0.0, 0.0, g.r_hypodermis, g.length),
        occ.addRectangle(g.r_hypodermis, 0.0, 0.0, g.r_dermis - g.r_hypodermis, g.length),
        occ.addRectangle(g.r_dermis, 0.0, 0.0, g.r_epidermis - g.r_dermis, g.length),
        *suture_surfaces(occ, g),
    ]


def suture_surfaces(occ: Any, g: Geometry) -> list[int]:
    """The suture's pieces of the half-section as OCC surfaces: the thread, then each cone."""
    thread = occ.addRectangle(0.0, 0.0, 0.0, g.r_thread, g.z_end)
    return [thread, *[_add_outline(occ, cone.outline) for cone in g.cones]]


def owners(pieces: list[list[tuple[int, int]]], n_cones: int) -> dict[int, int]:
    """Entity -> cell tag, from the fragment map of :func:`section_surfaces`' pieces (or their revolutions).

    The thread overrides the hypodermis it was cut from; the cones override both.
    """
    owner: dict[int, int] = {}
    for i, region in enumerate([Cell.HYPODERMIS, Cell.DERMIS, Cell.EPIDERMIS]):
        for _, tag in pieces[i]:
            owner.setdefault(tag, region)
    for _, tag in pieces[3]:
        owner[tag] = Cell.THREAD
    for k in range(n_cones):
        for _, tag in pieces[4 + k]:
            owner[tag] = Cell.CONE
    return owner


def add_groups(dim: int, owner: dict[int, int], facets: dict[int, set[int]]) -> None:
    """The physical groups: each region's entities of dimension ``dim`` and each facet tag's of ``dim - 1``."""
    import gmsh

    for region, tag in CELL_TAGS.items():
        entities = sorted(e for e, r in owner.items() if r == tag)
        if entities:
            gmsh.model.addPhysicalGroup(dim, entities, tag)
            gmsh.model.setPhysicalName(dim, tag, region)
    for fname, tag in FACET_TAGS.items():
        if facets[tag]:
            gmsh.model.addPhysicalGroup(dim - 1, sorted(facets[tag]), tag)
            gmsh.model.setPhysicalName(dim - 1, tag, fname)


def split_interfaces(owner: dict[int, int], facets: dict[int, set[int]], thread: bool = True,
                     cones: bool = False, dim: int = 2) -> int:
    """Give the tissue its own nodes along the bare thread (``thread``) and on the cones' surfaces (``cones``).

    Every mesh node on a split interface curve (end points included) is duplicated, except the nodes that
    also lie on an interface curve that stays tied (with the cones tied, the junctions where a cone meets
    the thread). The suture keeps the original nodes; the tissue's elements are rewritten to use the
    duplicates, which lie on new discrete curves carrying the physical groups ``track`` (the thread's) and
    ``cone_contact`` (the cones'); their line elements are the tissue's side of the interface. A node on
    both (where a split cone meets a split thread) has one duplicate. Call after meshing (and after
    ``setOrder``). Returns the number of nodes duplicated.

    ``dim`` 3: the same for the 3-D model (:mod:`suture_fem.geometry.gmsh_3d`), the interface's faces for its
    curves, its volumes for its surfaces; the tissue's boundary faces (the symmetry plane, its end faces) are
    rewritten on the duplicates too, so that their facet tags find the tissue's faces.
    """
    import gmsh

    mesh = gmsh.model.mesh
    fdim = dim - 1

    def sides(curve: int) -> set[int]:
        return {owner[s] for s in gmsh.model.getAdjacencies(fdim, curve)[0]}

    interface = sorted(facets[Facet.INTERFACE])
    on_thread = [c for c in interface if Cell.THREAD in sides(c) and sides(c) & set(TISSUE)]
    groups = {Facet.TRACK: on_thread if thread else [],
              Facet.CONE_CONTACT: [c for c in interface if c not in on_thread] if cones else []}
    split = groups[Facet.TRACK] + groups[Facet.CONE_CONTACT]
    tied = [c for c in interface if c not in split]
    if not split:
        return 0

    def curve_nodes(curve: int) -> np.ndarray:
        return np.asarray(mesh.getNodes(fdim, curve, includeBoundary=True)[0], dtype=np.int64)

    keep = set(np.concatenate([curve_nodes(c) for c in tied]).tolist()) if tied else set()
    old = sorted(set(np.concatenate([curve_nodes(c) for c in split]).tolist()) - keep)
    all_tags, all_xyz, _ = mesh.getNodes()
    xyz = dict(zip(np.asarray(all_tags, dtype=np.int64).tolist(), np.asarray(all_xyz).reshape(-1, 3).tolist()))
    first = int(np.max(all_tags)) + 1
    twin = {n: first + i for i, n in enumerate(old)}

    def remap(nodes: Any) -> np.ndarray:
        return np.array([twin.get(int(n), int(n)) for n in nodes], dtype=np.int64)

    _add_split_sides(groups, fdim, [(twin[n], xyz[n]) for n in old], remap)
    volumes = sorted(t for t, region in owner.items() if region in TISSUE)
    if dim == 3:  # the tissue's own faces first: the volumes' elements hold their nodes
        faces = sorted(f for _, f in gmsh.model.getEntities(2) if f not in set(split) and _tissue_only(owner, f))
        _remap_tissue([(2, f) for f in faces] + [(3, v) for v in volumes], remap)
    else:
        _remap_tissue([(2, v) for v in volumes], remap)
    mesh.renumberNodes()
    return len(old)


def _add_split_sides(groups: dict[Facet, list[int]], fdim: int, twins: list[tuple[int, list[float]]],
                     remap: Any) -> None:
    """One new discrete entity per split group, with the group's physical tag.

    It holds the duplicates (``twins``: tag and xyz; all of them on the first entity) and the tissue's side of the
    group's facet elements, rewritten on them.
    """
    import gmsh

    mesh = gmsh.model.mesh
    next_element = int(max(max((int(t) for t in tags), default=0) for tags in mesh.getElements()[1])) + 1
    placed = False
    for tag, curves in groups.items():
        if not curves:
            continue
        new_curve = gmsh.model.addDiscreteEntity(fdim)
        if not placed:  # every duplicate once, on the first new curve
            mesh.addNodes(fdim, new_curve, [t for t, _ in twins], [c for _, p in twins for c in p])
            placed = True
        for c in curves:
            for etype, etags, enodes in zip(*mesh.getElements(fdim, c)):
                new_tags = list(range(next_element, next_element + len(etags)))
                next_element += len(etags)
                mesh.addElements(fdim, new_curve, [etype], [new_tags], [remap(enodes).tolist()])
        gmsh.model.addPhysicalGroup(fdim, [new_curve], int(tag))
        gmsh.model.setPhysicalName(fdim, int(tag), tag.name.lower())


def _tissue_only(owner: dict[int, int], face: int) -> bool:
    """A face of the 3-D model with tissue on every side it has (a boundary or an interface between layers)."""
    import gmsh

    up = gmsh.model.getAdjacencies(2, face)[0]
    return len(up) > 0 and all(owner[v] in TISSUE for v in up)


def _remap_tissue(entities: list[tuple[int, int]], remap: Any) -> None:
    """The listed (dim, tag) entities' elements on the duplicates instead of the suture's nodes (same tags).

    Every entity touching a duplicate is read first, then all of them cleared (volumes before faces) and rebuilt in
    the listed order (their own nodes, then their elements): a face's nodes are also its volumes' nodes.
    """
    import gmsh

    mesh = gmsh.model.mesh
    rebuilt = []
    for dim, s in entities:
        inner_tags, inner_xyz, _ = mesh.getNodes(dim, s)
        etypes, etags, enodes = mesh.getElements(dim, s)
        remapped = [remap(nodes) for nodes in enodes]
        if all(np.array_equal(a, np.asarray(b, dtype=np.int64)) for a, b in zip(remapped, enodes)):
            continue  # touches no duplicated node
        rebuilt.append((dim, s, inner_tags, inner_xyz, etypes, etags, remapped))
    for dim in sorted({dim for dim, *_ in rebuilt}, reverse=True):  # gmsh keeps a face's mesh while a volume has one
        mesh.clear([(d, s) for d, s, *_ in rebuilt if d == dim])
    for dim, s, inner_tags, inner_xyz, etypes, etags, remapped in rebuilt:
        mesh.addNodes(dim, s, list(inner_tags), list(inner_xyz))
        for etype, tags, nodes in zip(etypes, etags, remapped):
            mesh.addElements(dim, s, [etype], [list(tags)], [nodes.tolist()])


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
            out[Facet.OUTER].add(c)
        elif r0 < tol and r1 < tol:
            out[Facet.AXIS].add(c)
        elif abs(z0 - g.z_end) < tol and abs(z1 - g.z_end) < tol:
            out[Facet.PULL_FACE].add(c)
        elif abs(z0 - g.length) < tol and abs(z1 - g.length) < tol and sides <= set(TISSUE):
            out[Facet.TISSUE_PULL_FACE].add(c)
        elif z1 < tol:  # on the far face z = 0
            out[Facet.THREAD_FAR_FACE if sides <= set(SUTURE) else Facet.TISSUE_FAR_FACE].add(c)
        elif len(up) == 1 and sides <= set(SUTURE) and z0 >= g.length - tol:
            out[Facet.THREAD_FREE_SIDE].add(c)
        if sides & set(SUTURE) and sides & set(TISSUE):
            out[Facet.INTERFACE].add(c)
    return out


def _size_fields(g: Geometry, sizes: MeshSizes, facets: dict[int, set[int]]) -> None:
    """Fine near the suture surface, finer at the cone corners, coarse far away."""
    import gmsh

    field = gmsh.model.mesh.field
    suture_curves = sorted(facets[Facet.INTERFACE] | facets[Facet.THREAD_FREE_SIDE] | facets[Facet.PULL_FACE])
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
    fields += _fillet_fields(sizes)
    combined = field.add("Min")
    field.setNumbers(combined, "FieldsList", fields)
    field.setAsBackgroundMesh(combined)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)


def fillet_arcs() -> list[tuple[int, float]]:
    """(curve tag, length in mm) of every circular arc of the current gmsh model: the cones' fillets."""
    import gmsh

    arcs = []
    for _, c in gmsh.model.getEntities(1):
        if gmsh.model.getType(1, c) == "Circle":
            lo, hi = gmsh.model.getParametrizationBounds(1, c)
            ends = gmsh.model.getValue(1, c, [lo[0], hi[0]])
            mid = gmsh.model.getValue(1, c, [0.5 * (lo[0] + hi[0])])
            chord = math.dist(ends[:2], ends[3:5])
            half = math.dist(ends[:2], mid[:2])
            # the arc's length from its chord c and the chord of its half h: radius = h^2 / sqrt(4 h^2 - c^2)
            radius = half**2 / math.sqrt(max(4 * half**2 - chord**2, 1e-300))
            arcs.append((c, 2 * radius * 2 * math.asin(min(1.0, half / (2 * radius)))))
    return arcs


def _fillet_fields(sizes: MeshSizes) -> list[int]:
    """One size field per fillet arc: ``sizes.fillet(length)`` on the arc, graded to the rim size nearby."""
    import gmsh

    field = gmsh.model.mesh.field
    out = []
    for curve, length in fillet_arcs():
        h = sizes.fillet(length)
        d = field.add("Distance")
        field.setNumbers(d, "CurvesList", [curve])
        compat.gmsh_set_distance_sampling(d, int(max(20, 4 * length / h)))
        t = field.add("Threshold")
        field.setNumber(t, "InField", d)
        field.setNumber(t, "SizeMin", h)
        field.setNumber(t, "SizeMax", sizes.rim)
        field.setNumber(t, "DistMin", 0.0)
        field.setNumber(t, "DistMax", FILLET_GRADING * sizes.rim)
        field.setNumber(t, "StopAtDistMax", 1)  # no constraint beyond: the other fields size the rest
        out.append(t)
    return out

