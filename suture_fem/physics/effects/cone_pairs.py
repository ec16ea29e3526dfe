"""The tissue's nodes on the cones' surfaces, their cones and lumped areas, for the cones' contact.

:func:`cone_pairs` reads them off a built Physics whose mesh has the cones' surfaces split
(:func:`~suture_fem.geometry.gmsh_model.split_interfaces`): each owned tissue node on a facet tagged
``cone_contact``, its cone, its 2 pi r-weighted lumped area (3-D: weighted by the half model's 2), and every cone's
axial dofs on its interface, with each cone's outline rounded at its sharp convex corners for the search
(:mod:`~suture_fem.physics.effects.cone_contact`) and closed to the axis: the cone and the thread inside it
searched as one body. The cone's own side on the thread faces no tissue, yet a node squeezed toward the
thread beside the apex cap found it nearer than the cap's face (a tied thread's sliding cone at 3 N: two cap
nodes 20-30 um inside the cap read as slipped 5 mm round the outline, pushed toward the axis).

With the thread free in its track too (``effects.thread_interface`` not tied), the tissue's nodes on the track
(facets tagged ``track``) join the search, each against the cone that slides toward it: the nearest cone whose
lower end lies at or below the node (the pull moves every cone toward +z), the first cone for the nodes
below every cone. A cone then pushes the track's tissue ahead of its apex instead of passing through it.

The tissue's next layer of nodes (of a tissue cell with a node on a cone's surface, themselves on no cone or track)
joins the search too, each against its nearest cone at rest, as unilateral and frictionless whatever the cones'
model (held off the cones with nothing tied; with the thread tied only measured, by :class:`WatchedLayer`, and not
among the pairs, so the solve is the one without them): tissue
sliding round a cone's corner stretches its facets there and draws these nodes onto the cone, which the surface's
nodes alone let through (docs/contact.md, "The apex-cap stall"). At rest they lie an element off the cone, so until
one touches, nothing changes. Having no facet, each has the area of a facet one suture element long: 2 pi r h (3-D:
the half model's 2 h^2).
"""

from __future__ import annotations

import math
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.outline import meridian, project
from suture_fem.geometry.regions import Facet
from suture_fem.physics.constraints import mark_dofs, mark_facet_nodes
from suture_fem.physics.effects import cone_frame
from suture_fem.physics.effects.friction import global_dofs
from suture_fem.physics.kinematics import HALF_MODEL_WEIGHT
from suture_fem.support import compat

#: The search rounds each sharp corner of a cone (off the thread) by this fraction of the suture's element size.
CORNER_ROUNDING = 0.1


def cone_pairs(physics: Any, hold_next_layer: bool = True) -> dict[str, Any]:
    """The owned cone-contact nodes of the tissue, their cones, lumped areas and the cones' axial dofs (collective).

    ``hold_next_layer``: the next layer joins the pairs (``near``); else it is returned apart, ``watched``.
    """
    V, mesh, tagged = physics.V, physics.mesh, physics.tagged
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    n_local = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    owned = V.dofmap.index_map.size_local
    facets = meshmod.facets(tagged, Facet.CONE_CONTACT)
    if mesh.comm.allreduce(len(facets)) == 0:
        raise ValueError("effects.cone_interface needs the mesh built with the cones' surfaces split "
                         "(suture_fem.geometry.mesh.scene_mesh, or create_mesh(..., split_cones=True))")
    suture = mark_dofs(V, meshmod.region_cells(tagged, regions.SUTURE)).reshape(n_local, -1).any(axis=1)
    on_cones = mark_facet_nodes(V, fdim, facets) & ~suture  # a node's facets may be on another rank
    nodes = np.flatnonzero(on_cones)
    nodes = nodes[nodes < owned]
    v, x, dim = ufl.TestFunction(V), ufl.SpatialCoordinate(mesh), mesh.geometry.dim
    weighted = v[1] * 2 * math.pi * x[0] if dim == 2 else v[1] * HALF_MODEL_WEIGHT  # the 3-D half model's 2
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged.facet_tags)
    area = _assembled(weighted * ds(int(Facet.CONE_CONTACT)), owned, dim)[:, 1]  # the lumped area
    xyz = V.tabulate_dof_coordinates()[:, :dim] / regions.MM
    xy = meridian(xyz)  # (r, axial): in 3-D (sqrt(x^2 + z^2), y)
    cones = tagged.geometry.cones
    rho = CORNER_ROUNDING * tagged.sizes.suture
    cone = _cone_of(xy[nodes], cones, tagged.geometry.z_end)
    own = np.ones(len(nodes), dtype=bool)  # on a cone's own surface
    track_facets = meshmod.facets(tagged, Facet.TRACK)
    free = bool(mesh.comm.allreduce(len(track_facets)))
    if free:  # the thread free in its track: its tissue joins the search
        track = np.flatnonzero(mark_facet_nodes(V, fdim, track_facets) & ~suture & ~on_cones)
        track = track[track < owned]
        track_area = _assembled(weighted * ds(int(Facet.TRACK)), owned, dim)[:, 1]
        nodes = np.concatenate([nodes, track])
        cone = np.concatenate([cone, _cone_behind(xy[track], cones)])
        area[track] = track_area[track]
        own = np.concatenate([own, np.zeros(len(track), dtype=bool)])
    else:
        track = np.zeros(0, dtype=np.int64)
    outlines = [c.rounded(rho, tagged.geometry.r_thread, to_axis=True) for c in cones]
    watched = _next_layer(physics, on_cones, suture, track, xyz, outlines)
    if hold_next_layer:  # among the pairs
        near = watched["nodes"]
        nodes, cone = np.concatenate([nodes, near]), np.concatenate([cone, watched["cone"]])
        area[near] = _facet_like_area(xyz[near], tagged.sizes.suture * regions.MM)
        watched = {key: value[:0] for key, value in watched.items()}
    layer = np.concatenate([np.zeros(len(own), dtype=bool), np.ones(len(nodes) - len(own), dtype=bool)])
    own = np.concatenate([own, np.zeros(len(nodes) - len(own), dtype=bool)])
    cone_dofs = _cone_axial_dofs(physics, xy)
    dofs = np.stack([global_dofs(physics, nodes, c) for c in range(dim)], axis=1)
    return {"nodes": nodes, "dofs": dofs, "X": xyz[nodes], "cone": cone, "weight": area[nodes], "surface": own,
            "near": layer, "watched": watched, "hold_next_layer": hold_next_layer, "cone_dofs": cone_dofs,
            "corner_mm": rho, "outlines": outlines}


def _cone_axial_dofs(physics: Any, xy: np.ndarray) -> list[np.ndarray]:
    """Per cone, the global axial dofs of its interface nodes, every rank's (collective); xy: (r, axial) per node."""
    V, tagged = physics.V, physics.tagged
    n_local, owned = len(xy), V.dofmap.index_map.size_local
    cone_cells = mark_dofs(V, meshmod.region_cells(tagged, regions.Cell.CONE)).reshape(n_local, -1).any(axis=1)
    faces = mark_facet_nodes(V, physics.mesh.topology.dim - 1, meshmod.facets(tagged, Facet.INTERFACE))
    surface = np.flatnonzero(cone_cells & faces)
    surface = surface[surface < owned]
    of_surface = _cone_of(xy[surface], tagged.geometry.cones, tagged.geometry.z_end)
    axial = global_dofs(physics, surface, 1)
    return [np.concatenate(physics.comm.allgather(axial[of_surface == c])).astype(np.int64)
            for c in range(len(tagged.geometry.cones))]


class WatchedLayer:
    """The next layer's nodes measured, not held (the thread tied): how deep inside its nearest cone each lies."""

    def __init__(self, state: Any, watched: dict[str, np.ndarray] | None, outlines: list, dim: int):
        """``state``: the state's PETSc vector; ``watched``: :func:`cone_pairs`'s ``watched`` (this rank's), or None."""
        if watched is None:
            watched = {"dofs": np.zeros((0, dim), dtype=np.int64), "X": np.zeros((0, dim)), "cone": np.zeros(0, int)}
        self.X, self.cone, self.outlines = watched["X"], watched["cone"], outlines
        self.count = len(self.cone)
        self._local = PETSc.Vec().createSeq(watched["dofs"].size, comm=PETSc.COMM_SELF)
        index = PETSc.IS().createGeneral(watched["dofs"].ravel().astype(PETSc.IntType), comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(state, index, self._local, None)
        index.destroy()

    def depth(self, u_vec: Any, t_c: np.ndarray) -> float:
        """The deepest watched node inside its cone (m, 0 with none inside) on this rank; t_c: the cones' shifts (m)."""
        self._scatter.scatter(u_vec, self._local, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        u = self._local.getArray(readonly=True).reshape(self.count, self.X.shape[1])  # collective, even when empty
        y = cone_frame.moved(self.X, u, t_c[self.cone], regions.MM)[0]
        deepest = 0.0
        for c, outline in enumerate(self.outlines):
            sel = self.cone == c
            if sel.any():
                deepest = max(deepest, float(np.max(-project(y[sel], outline).distance)) * regions.MM)
        return deepest

    def destroy(self) -> None:
        """Free the scatter and its local vector."""
        self._scatter.destroy()
        self._local.destroy()


def _facet_like_area(xyz_mm: np.ndarray, h: float) -> np.ndarray:
    """A next-layer node's area (m^2): that of a facet one suture element (h, m) long, 2 pi r h (3-D: 2 h^2)."""
    if xyz_mm.shape[1] == 2:
        return 2 * math.pi * xyz_mm[:, 0] * regions.MM * h
    return np.full(len(xyz_mm), HALF_MODEL_WEIGHT * h * h)


def _next_layer(physics: Any, on_cones: np.ndarray, suture: np.ndarray, track: np.ndarray, xyz: np.ndarray,
                outlines: list) -> dict[str, np.ndarray]:
    """The next layer's owned nodes, their global dofs (nodes, dim), positions (mm) and nearest cones (collective).

    The nodes of the tissue cells with a node ``on_cones``, themselves on no cone, suture or ``track``.
    ``on_cones``, ``suture``: per local node; ``track``: the track's owned nodes in the search; ``xyz``: every
    local node's reference position (mm).
    """
    V, tagged, dim = physics.V, physics.tagged, physics.mesh.geometry.dim
    n_cells = physics.mesh.topology.index_map(physics.mesh.topology.dim).size_local
    cells = np.setdiff1d(np.arange(n_cells, dtype=np.int32), meshmod.region_cells(tagged, regions.SUTURE))
    touching = cells[on_cones[compat.cell_dofs(V)[cells]].any(axis=1)].astype(np.int32)
    layer = mark_dofs(V, touching).reshape(len(on_cones), -1).any(axis=1) & ~on_cones & ~suture
    layer[track] = False
    near = np.flatnonzero(layer[: V.dofmap.index_map.size_local])
    return {"nodes": near, "dofs": np.stack([global_dofs(physics, near, c) for c in range(dim)], axis=1),
            "X": xyz[near], "cone": nearest_cone(meridian(xyz[near]), outlines)}


def nearest_cone(xy_mm: np.ndarray, outlines: list) -> np.ndarray:
    """The cone whose outline is nearest to each point ((n, 2) mm, the meridian plane)."""
    if len(xy_mm) == 0:
        return np.zeros(0, dtype=np.int64)
    distance = np.stack([np.abs(project(xy_mm, outline).distance) for outline in outlines], axis=1)
    return np.argmin(distance, axis=1).astype(np.int64)


def _cone_of(xy_mm: np.ndarray, cones: list, z_end: float) -> np.ndarray:
    """The cone whose axial extent holds each point (-1 for none)."""
    tol = 1e-9 * max(z_end, 1.0)
    out = np.full(len(xy_mm), -1, dtype=np.int64)
    for k, c in enumerate(cones):
        lo, hi = min(c.base_z, c.apex_z), max(c.base_z, c.apex_z)
        out[(xy_mm[:, 1] >= lo - tol) & (xy_mm[:, 1] <= hi + tol)] = k
    return out


def _cone_behind(xy_mm: np.ndarray, cones: list) -> np.ndarray:
    """For each point, the cone that slides toward it: the one whose lower end is the highest at or below it."""
    lower = np.array([min(c.base_z, c.apex_z) for c in cones])
    behind = np.searchsorted(np.sort(lower), xy_mm[:, 1], side="right") - 1
    return np.argsort(lower)[np.maximum(behind, 0)].astype(np.int64)


def _assembled(linear: Any, owned: int, dim: int) -> np.ndarray:
    """A vector form's owned nodal values, (owned, dim) (collective)."""
    b = dolfinx.fem.petsc.assemble_vector(compat.form(linear))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    values = b.array[: dim * owned].reshape(-1, dim).copy()
    b.destroy()
    return values
