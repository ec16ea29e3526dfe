"""The 3-D critical-distance search (outputs/ball_search.py) on tetrahedral boxes with known largest ball averages.

No solve: cell-wise fields given by hand on half-model boxes (z <= 0, read on the mirror), as a 3-D scene's
stress is; also run on 2 ranks by tests/mpi/test_ball_parallel.py.
"""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
import pytest
from mpi4py import MPI

from suture_fem.outputs.ball_search import BallRegion, ball_maxima
from suture_fem.support import compat

N, RADIUS = 8, 0.2
H = np.sqrt(3.0) / N  # the cells' diameter


def _half_box() -> tuple[BallRegion, np.ndarray]:
    """The box [0, 1] x [0, 1] x [-1, 0] (the half model below its symmetry plane z = 0) and its cell centroids."""
    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.array([0.0, 0.0, -1.0]), np.array([1.0, 1.0, 0.0])],
                                   [N, N, N], dolfinx.mesh.CellType.tetrahedron)
    owned = mesh.topology.index_map(3).size_local
    ball = BallRegion(mesh, np.arange(owned, dtype=np.int32), RADIUS, mirror_z=True)
    mid = mesh.geometry.x[compat.geometry_dofs(mesh)[:owned, :4]].mean(axis=1)
    return ball, mid


def test_a_broad_plateau_beats_a_narrow_spike_and_the_near_search_stays_near():
    """A spike of 4 in a few small cells and a plateau of 1 wider than the ball: the largest ball average is exactly 1.

    The spike holds the largest cell value (the first candidate), but its ball averages far less; a ball
    on the symmetry plane inside the plateau, read whole on the mirror, averages 1 exactly. The search
    restricted to centres near the spike (as near a cone) finds the spike's ball, under 1.
    """
    ball, mid = _half_box()
    values = np.where(np.all(mid > [0.45, 0.45, -0.55], axis=1), 1.0, 0.0)  # a plateau 0.55 wide, on the plane
    # the tetrahedra of one hexahedron of the box's grid, [1/8, 2/8]^2 x [-7/8, -6/8]: (1/8)^3 is 0.058 of the
    # ball's volume. The rule's 288 points sample a field this discontinuous unevenly: the best-placed ball
    # puts 0.13 of its weight in the hexahedron (a 10 there averaged 1.29), so 4 keeps every ball below 1
    spike = np.all((mid > [0.125, 0.125, -0.875]) & (mid < [0.25, 0.25, -0.75]), axis=1)
    values[spike] = 4.0
    assert MPI.COMM_WORLD.allreduce(int(spike.sum()), op=MPI.SUM) == 6

    def allowed(c: np.ndarray) -> np.ndarray:
        return np.linalg.norm(np.asarray(c).reshape(-1, 3) - [0.1875, 0.1875, -0.8125], axis=1) <= 0.3

    found, near = ball_maxima(ball, values, (allowed, allowed(ball.centroids)))
    assert found.value == pytest.approx(1.0, rel=1e-12)
    assert np.all(np.array(found.at) > [0.45 + RADIUS - H, 0.45 + RADIUS - H, -0.55 + RADIUS - H])  # in the plateau
    assert near.at is not None and allowed(np.array(near.at))[0]
    assert 0.0 < near.value < 1.0


def test_a_linear_field_peaks_on_the_edge_where_a_quarter_ball_remains():
    """g = x + 2y, cell-wise at the centroids: largest on the edge x = y = 1, over a quarter ball (with its mirror).

    The quarter ball's centroid lies 3R/8 inside each cut face, so the exact largest average is
    3 (1 - 3R/8); the cell-wise field is within |grad g| h of g at every point, so the average is too.
    """
    ball, mid = _half_box()
    grad = np.array([1.0, 2.0, 0.0])
    found, near = ball_maxima(ball, mid @ grad, None)
    assert near is None
    assert abs(found.value - 3.0 * (1.0 - 3.0 * RADIUS / 8.0)) <= np.linalg.norm(grad) * H
    assert found.at[0] >= 1.0 - H and found.at[1] >= 1.0 - H and found.at[2] <= 0.0


def test_the_tetrahedra_locator_finds_dolfinxs_cells():
    """compat.cell_locator's barycentric test gives dolfinx's (GJK) cells, points on shared faces and vertices too."""
    import dolfinx.geometry as geo

    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.zeros(3), np.ones(3)], [4, 4, 4],
                                   dolfinx.mesh.CellType.tetrahedron)
    owned = mesh.topology.index_map(3).size_local
    cells = np.arange(owned, dtype=np.int32)
    x = mesh.geometry.x[compat.geometry_dofs(mesh)[:owned, :4]]
    points = np.concatenate([np.random.default_rng(1).random((500, 3)), x[:, 0],  # inside; vertices
                             x[:, :3].mean(axis=1)])  # the centres of faces: on a face two cells share
    idx, found = compat.cell_locator(mesh, cells)(points, keep=False)
    tree = geo.bb_tree(mesh, 3, cells) if hasattr(geo, "bb_tree") else geo.BoundingBoxTree(mesh, 3, cells)
    collide = geo.compute_collisions_points if hasattr(geo, "compute_collisions_points") else geo.compute_collisions
    hits = geo.compute_colliding_cells(mesh, collide(tree, points), points)
    expected = set(zip(np.repeat(np.arange(len(points)), np.diff(hits.offsets)).tolist(), hits.array.tolist()))
    assert set(zip(idx.tolist(), found.tolist())) == expected
    assert len(expected) > len(points)  # the vertices and faces are in several cells
