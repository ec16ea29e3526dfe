"""The 3-D critical-distance ball (outputs/ball.py): its rule, and averages on tetrahedral boxes (no solve)."""

from __future__ import annotations

import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from suture_fem.outputs.ball import ball_averages, ball_rule
from suture_fem.support import compat


def _box(lo, hi, n):
    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.array(lo, float), np.array(hi, float)], [n, n, n],
                                   dolfinx.mesh.CellType.tetrahedron)
    owned = mesh.topology.index_map(3).size_local
    cells = np.arange(owned, dtype=np.int32)
    x = mesh.geometry.x[compat.geometry_dofs(mesh)[:owned, :4]]  # (cells, 4 vertices, 3)
    return mesh, compat.cell_locator(mesh, cells), x.mean(axis=1)


def test_rule_integrates_the_ball_moments():
    radius = 0.3
    offsets, weights = ball_rule(radius)
    volume = 4.0 / 3.0 * np.pi * radius**3
    assert np.isclose(weights.sum(), volume, rtol=1e-13)
    assert np.allclose(weights @ offsets, 0.0, atol=1e-15)  # first moments vanish
    second = np.einsum("k,ki,kj->ij", weights, offsets, offsets)  # int x_i x_j = 4 pi R^5 / 15 delta_ij
    assert np.allclose(second, 4.0 * np.pi * radius**5 / 15.0 * np.eye(3), rtol=1e-12, atol=1e-18)
    assert np.all(np.linalg.norm(offsets, axis=1) < radius) and not np.any(offsets[:, 2] == 0.0)


def test_average_of_a_linear_field_inside_and_the_part_in_the_region():
    n, radius = 8, 0.2
    mesh, locate, mid = _box([0, 0, 0], [1, 1, 1], n)
    grad = np.array([1.0, -2.0, 0.5])
    centres = np.array([[0.5, 0.5, 0.5], [0.5, 0.5, 0.0]])  # inside; on the face z = 0
    avg, volume = ball_averages(mesh.comm, locate, mid @ grad, centres, radius)
    full = 4.0 / 3.0 * np.pi * radius**3
    assert np.isclose(volume[0], full, rtol=1e-12) and np.isclose(volume[1], full / 2, rtol=1e-12)
    h = np.sqrt(3.0) / n  # the cells' diameter: the cell-wise field is within |grad| h of the linear one
    assert abs(avg[0] - centres[0] @ grad) <= np.linalg.norm(grad) * h
    # the half ball in z >= 0 averages z to 3 R / 8 above the face
    assert abs(avg[1] - (centres[1] @ grad + grad[2] * 3.0 * radius / 8.0)) <= np.linalg.norm(grad) * h
    const, _ = ball_averages(mesh.comm, locate, np.ones(len(mid)), centres, radius)
    assert np.allclose(const, 1.0, rtol=1e-14)


def test_mirror_makes_the_half_model_a_whole_ball():
    """On the half model z <= 0 a ball on the symmetry plane is read whole, at the mirror images."""
    n, radius = 8, 0.2
    mesh, locate, mid = _box([0, 0, -1], [1, 1, 0], n)
    grad = np.array([1.0, -2.0, 0.0])  # even in z, as a scalar stress measure of the symmetric solid
    centre = np.array([[0.5, 0.5, 0.0]])
    half, v_half = ball_averages(mesh.comm, locate, mid @ grad, centre, radius)
    whole, v_whole = ball_averages(mesh.comm, locate, mid @ grad, centre, radius, mirror_z=True)
    assert np.isclose(v_whole[0], 2.0 * v_half[0], rtol=1e-12)
    assert np.isclose(v_whole[0], 4.0 / 3.0 * np.pi * radius**3, rtol=1e-12)
    assert np.isclose(whole[0], half[0], rtol=1e-12)  # the field is even in z: the mirrored half adds the same
    outside, v_out = ball_averages(mesh.comm, locate, mid @ grad, np.array([[5.0, 5.0, 5.0]]), radius)
    assert np.isnan(outside[0]) and v_out[0] == 0.0


def test_overlap_volumes_give_the_cap_and_a_small_cluster_where_the_rule_is_off():
    """A field 1 in the half space x > 1/2 (a mesh plane) and 0 below: the ball's average is its cap's volume
    share, pi h^2 (3R - h) / 3 over 4 pi R^3 / 3 (h = R - d at a distance d); and 1 in a cube of 2 x 2 x 2 of
    the mesh's hexahedra well inside the ball: the cube's volume over the ball's. The overlap volumes are exact
    but for the sampled cells on the sphere; the 288-point rule is off by more (measured 0.03 on the cap, tens of
    per cent on the cluster)."""
    from suture_fem.outputs.ball_search import BallRegion

    n, radius = 12, 0.2
    mesh = dolfinx.mesh.create_box(MPI.COMM_WORLD, [np.zeros(3), np.ones(3)], [n, n, n],
                                   dolfinx.mesh.CellType.tetrahedron)
    region = BallRegion(mesh, np.arange(mesh.topology.index_map(3).size_local, dtype=np.int32), radius, False)
    half = (region.centroids[:, 0] > 0.5).astype(float)
    d = np.array([0.0, 0.05, 0.1, 0.15, -0.07])
    centres = np.column_stack([0.5 - d, np.full(5, 0.5), np.full(5, 0.5)])
    h = radius - d
    cap = h**2 * (3.0 * radius - h) / (4.0 * radius**3)
    assert np.all(np.abs(region.averages(half, centres) - cap) < 1e-3)  # measured up to 4.4e-4 (512 samples a cut cell)
    assert np.max(np.abs(region.rule_averages(half, centres) - cap)) > 1e-2
    side = 2.0 / n
    cube = np.all(np.abs(region.centroids - 0.5) < side / 2, axis=1).astype(float)  # the 2 x 2 x 2 hexahedra
    share = side**3 / (4.0 / 3.0 * np.pi * radius**3)
    centres = np.array([[0.5, 0.5, 0.5], [0.52, 0.51, 0.5]])
    assert np.allclose(region.averages(cube, centres), share, rtol=2e-3)
    assert np.all(np.abs(region.rule_averages(cube, centres) / share - 1.0) > 0.2)
