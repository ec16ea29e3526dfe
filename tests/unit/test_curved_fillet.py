"""Quadratic cells on the fillet arcs (``mesh.geometry_degree = 2``): their mid-side nodes lie on the arcs,
a scene without arcs keeps straight cells, and the key needs the isoparametric displacement degree."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import MM
from suture_fem.pipeline import load_scene
from suture_fem.support.errors import SceneError

ONE_ROUNDED_CONE = ["geometry.cones=1", "geometry.cone_fillet_mm=0.04", "mesh.fillet_elements=8", "mesh.degree=2"]


def _arc_nodes(overrides):
    """(the mesh's geometry degree, the number of mesh nodes on each fillet arc), on one rank."""
    scene = load_scene("paper", overrides)
    tagged = meshmod.create_mesh(MPI.COMM_SELF, scene.geometry, scene.mesh)
    x = tagged.mesh.geometry.x[:, :2] / MM
    counts = []
    for cone in tagged.geometry.cones:
        for kind, seg in cone.outline:
            if kind != "arc":
                continue
            start, centre, end = (np.asarray(p, dtype=float) for p in seg)
            radius = np.hypot(*(start - centre))
            d = np.hypot(*(x - centre).T)
            on_circle = np.abs(d - radius) <= 1e-9 * radius
            # on the arc: on its circle and between its end points (the arc is under a half turn)
            chord = end - start
            side = np.sign(_cross(chord, centre - start))
            between = np.sign(_cross(chord, x - start)) != side
            counts.append(int(np.sum(on_circle & (between | (np.hypot(*(x - start).T) < 1e-12)
                                                  | (np.hypot(*(x - end).T) < 1e-12)))))
    return meshmod.geometry_degree(tagged.mesh), counts


def _cross(a, b):
    """The z component of a x b for 2-D vectors (b may be (n, 2)); np.cross of 2-D vectors is deprecated in numpy 2."""
    b = np.asarray(b)
    return a[0] * b[..., 1] - a[1] * b[..., 0]


def test_quadratic_cells_put_their_mid_side_nodes_on_the_arcs():
    straight_degree, straight = _arc_nodes(ONE_ROUNDED_CONE)
    curved_degree, curved = _arc_nodes(ONE_ROUNDED_CONE + ["mesh.geometry_degree=2"])
    assert (straight_degree, curved_degree) == (1, 2)
    assert len(straight) == 2 and min(straight) >= 9  # a hollow cone's two base rims, 8 segments or more each
    # every segment of the arc gains its mid-side node, on the circle: n vertices -> 2 n - 1 nodes
    assert curved == [2 * n - 1 for n in straight]


def test_quadratic_cells_only_where_there_are_arcs():
    degree, counts = _arc_nodes(["geometry.cones=1", "mesh.degree=2", "mesh.geometry_degree=2"])
    assert (degree, counts) == (1, [])  # sharp rims: no curve to follow, the cells stay straight


def test_quadratic_cells_need_the_isoparametric_degree():
    with pytest.raises(SceneError, match=r"mesh.geometry_degree = 2 .* needs mesh.degree = 2"):
        load_scene("paper", ["mesh.degree=1", "mesh.geometry_degree=2", "geometry.cone_fillet_mm=0.04"])


def _curved_mesh():
    scene = load_scene("paper", ONE_ROUNDED_CONE + ["mesh.geometry_degree=2"])
    return meshmod.create_mesh(MPI.COMM_SELF, scene.geometry, scene.mesh).mesh


def test_a_quadratic_cells_vertices_come_first():
    """The locator and the fold check read a cell's first three nodes as its vertices, then the mid-side nodes."""
    from suture_fem.support import compat

    mesh = _curved_mesh()
    x = mesh.geometry.x[:, :2][compat.geometry_dofs(mesh)]
    mid = np.stack([(x[:, 1] + x[:, 2]) / 2, (x[:, 0] + x[:, 2]) / 2, (x[:, 0] + x[:, 1]) / 2], axis=1)
    off = np.linalg.norm(x[:, 3:] - mid, axis=2).max(axis=1) / np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    curved = off > 1e-9
    assert 0 < curved.sum() < 0.05 * len(off)  # only the cells on the arcs bulge
    assert off.max() < 0.1  # and only a little (the arc's sagitta over the edge)


def test_a_folded_quadratic_cell_is_found():
    from suture_fem.support import compat

    mesh = _curved_mesh()
    assert meshmod.folded_cells(mesh) == 0
    nodes = compat.geometry_dofs(mesh)[0]
    x = mesh.geometry.x
    towards_edge = 0.5 * (x[nodes[1], :2] + x[nodes[2], :2]) - x[nodes[0], :2]
    x[nodes[3], :2] = x[nodes[0], :2] - 0.5 * towards_edge
    assert meshmod.folded_cells(mesh) >= 1  # the mid-side node of edge (1, 2) pulled past vertex 0
