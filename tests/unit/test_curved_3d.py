"""Quadratic tetrahedra (``mesh.geometry_degree = 2`` in 3-D): their mid-edge nodes lie on the model's curved
surfaces, the volume of the revolved section is then exact to the geometry's order, a folded cell is found (between
any sample points too), and a cell the curving folds is straightened before the mesh leaves gmsh."""

from __future__ import annotations

import math

import dolfinx.fem
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from suture_fem.geometry import curved
from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import MM
from suture_fem.pipeline import load_scene
from suture_fem.support import compat

#: The coarsest 3-D cylinder of docs/three-d.md (the [mesh] sizes times 5.66), one cone, P2.
COARSE = ["geometry.dimension=3", "geometry.cones=1", "mesh.degree=2", "mesh.size_suture_mm=0.849",
          "mesh.size_rim_mm=0.283", "mesh.size_far_mm=6.79"]


@pytest.fixture(scope="module")
def meshes():
    """The straight and the curved mesh of the same scene, on one rank."""
    out = {}
    for degree in (1, 2):
        scene = load_scene("paper", [*COARSE, f"mesh.geometry_degree={degree}"])
        out[degree] = meshmod.create_mesh(MPI.COMM_SELF, scene.geometry, scene.mesh)
    return out


def _volume_error(tagged) -> float:
    """The mesh's volume against the revolved section's, relative: the tissue cylinder and the thread beyond it."""
    mesh, g = tagged.mesh, tagged.geometry
    volume = dolfinx.fem.assemble_scalar(compat.form(dolfinx.fem.Constant(mesh, 1.0) * ufl.dx(domain=mesh))) / MM**3
    exact = math.pi / 2 * (g.r_epidermis ** 2 * g.length + g.r_thread ** 2 * (g.z_end - g.length))
    return volume / exact - 1.0


def test_the_weight_integrates_the_curved_cells(meshes):
    """The gravity record's weight (its own integration of the cells' volumes) is the mesh's volume times rho g."""
    from suture_fem.geometry.regions import REGION_OF_TAG
    from suture_fem.physics.effects.gravity import weight_n
    from suture_fem.scene import Scene

    effects = Scene.from_values({"effects.gravity": True}).effects
    for tagged in meshes.values():
        mesh = tagged.mesh
        rho = {int(tag): effects.density(region) for tag, region in REGION_OF_TAG.items()}
        by_cell = dolfinx.fem.Function(compat.scalar_space(mesh, "DG", 0))
        by_cell.x.array[tagged.cell_tags.indices] = [rho[int(t)] for t in tagged.cell_tags.values]
        mass = 2.0 * dolfinx.fem.assemble_scalar(compat.form(by_cell * ufl.dx(domain=mesh)))
        assert weight_n(tagged, effects) == pytest.approx(mass * effects.gravity_m_s2, rel=1e-12)


def _on_cylinder(tagged, radius: float) -> int:
    """Mesh nodes on the cylinder r = radius about the thread's axis (y)."""
    x = tagged.mesh.geometry.x / MM
    return int(np.sum(np.abs(np.hypot(x[:, 0], x[:, 2]) - radius) <= 1e-9 * radius))


def test_curved_tetrahedra_follow_the_curved_surfaces(meshes):
    straight, curved = meshes[1], meshes[2]
    assert (meshmod.geometry_degree(straight.mesh), meshmod.geometry_degree(curved.mesh)) == (1, 2)
    # faceted, 6 elements on the thread's half circle: the outer cylinder's polygon loses about 0.6 % of the volume;
    # quadratic cells on the same vertices: 3e-6 (measured)
    assert abs(_volume_error(straight)) > 1e-3
    assert abs(_volume_error(curved)) < abs(_volume_error(straight)) / 100
    # a surface's edges gain their mid-edge nodes on it: about three edges per vertex (measured 3.7 times the nodes)
    for radius in (curved.geometry.r_thread, curved.geometry.r_epidermis):
        assert _on_cylinder(curved, radius) > 3 * _on_cylinder(straight, radius)


def test_a_quadratic_tetrahedrons_vertices_come_first(meshes):
    """The fold check and the overlaps read a cell's first four nodes as its vertices, then the mid-edge nodes."""
    mesh = meshes[2].mesh
    x = mesh.geometry.x[compat.geometry_dofs(mesh)]
    edges = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))  # basix's order of the mid-edge nodes
    mid = np.stack([(x[:, a] + x[:, b]) / 2 for a, b in edges], axis=1)
    length = np.stack([np.linalg.norm(x[:, a] - x[:, b], axis=1) for a, b in edges], axis=1)
    off = np.linalg.norm(x[:, 4:] - mid, axis=2) / length
    # the cells with an edge on a curved surface bulge (72 % here: the layers' cylinders are curved too), the rest not
    assert 0 < np.sum(off.max(axis=1) > 1e-9) < len(off)
    assert off.max() < 0.1  # a little: a sagitta over its chord


def test_a_folded_quadratic_tetrahedron_is_found(meshes):
    mesh = meshes[2].mesh
    assert meshmod.folded_cells(mesh) == 0
    nodes = compat.geometry_dofs(mesh)[0]
    x = mesh.geometry.x
    saved = x[nodes[4]].copy()
    towards_edge = 0.5 * (x[nodes[2]] + x[nodes[3]]) - x[nodes[0]]
    x[nodes[4]] = x[nodes[0]] - 0.5 * towards_edge  # the mid-edge node of edge (2, 3) pulled past vertex 0
    try:
        assert meshmod.folded_cells(mesh) >= 1
    finally:
        x[nodes[4]] = saved


def test_the_model_record_names_the_curved_cells(meshes):
    assert meshmod.describe(meshes[2])["model_3d"]["cells"] == meshmod.CURVED_3D
    assert "straight-sided" in meshmod.describe(meshes[1])["model_3d"]["cells"]


def _tetrahedron(bulge: float) -> np.ndarray:
    """A reference-shaped quadratic tetrahedron (basix's node order) whose edge (2, 3) bows toward vertex 0."""
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mids = [(v[a] + v[b]) / 2 for a, b in curved.EDGES[3]]
    mids[0] = mids[0] - bulge * mids[0]  # edge (2, 3)'s mid-node moved toward vertex 0 by ``bulge`` of its distance
    return np.concatenate([v, np.array(mids)])[None]


def test_the_bernstein_bound_finds_every_fold_a_dense_sample_finds():
    """Where the Jacobian (a cubic) is negative at any point of a dense lattice, the cell counts as folded."""
    n = 12
    lattice = [(i / n, j / n, k / n) for i in range(n + 1) for j in range(n + 1 - i) for k in range(n + 1 - i - j)]
    found = []
    for bulge in np.linspace(0.0, 1.2, 61):
        x = _tetrahedron(bulge)
        negative = bool(np.any(curved.jacobian_dets(x, lattice) <= 0.0))
        flagged = bool(curved.folded(x)[0])
        assert flagged or not negative, bulge  # never a fold missed
        found.append((negative, flagged))
    assert found[0] == (False, False)  # the straight cell
    assert found[-1] == (True, True)  # the node pulled past the opposite vertex
    # the bound is conservative: it flags a little before the cubic turns negative, never after
    first = {k: next(i for i, f in enumerate(found) if f[k]) for k in (0, 1)}
    assert first[1] <= first[0]


def test_a_cell_the_curving_folds_is_straightened_in_gmsh(monkeypatch):
    """The coarse full cone's curved mesh is built with no folded cell: each cell the curving folded is straightened.

    gmsh 4.8 (Debian 12) folds one sliver on the thread there, gmsh 4.13 (Debian 13) none. Before, gmsh's node
    order is checked: each mid-edge node, read in basix's order, lies nearest its own edge's chord midpoint.
    """
    from suture_fem.geometry import gmsh_3d

    counts, folded_before = [], []

    def counted(*args, **kwargs):
        _, _, x = curved._gmsh_tetrahedra()
        mids = np.stack([(x[:, a] + x[:, b]) / 2 for a, b in curved.EDGES[3]], axis=1)  # (cells, 6 edges, 3)
        distance = np.linalg.norm(x[:, 4:, None, :] - mids[:, None, :, :], axis=3)  # (cells, 6 nodes, 6 edges)
        assert np.all(np.argmin(distance, axis=2) == np.arange(6))
        folded_before.append(int(np.sum(curved.folded(x))))
        counts.append(curved.straighten_folded_gmsh(*args, **kwargs))
        return counts[-1]

    monkeypatch.setattr(gmsh_3d, "straighten_folded_gmsh", counted)
    scene = load_scene("paper", [*COARSE[:1], "geometry.cones=1", 'geometry.cone_kind="full"', "mesh.degree=2",
                                 "mesh.size_suture_mm=0.5", "mesh.size_rim_mm=0.25", "mesh.size_far_mm=3.0",
                                 "geometry.margin_far_mm=1.5", "geometry.margin_pull_mm=1.5", "mesh.geometry_degree=2"])
    tagged = meshmod.create_mesh(MPI.COMM_SELF, scene.geometry, scene.mesh)
    assert len(counts) == 1 and counts[0] >= folded_before[0]  # every folded cell straightened (gmsh 4.8: 1)
    assert meshmod.geometry_degree(tagged.mesh) == 2 and meshmod.folded_cells(tagged.mesh) == 0


def test_straightening_puts_a_folded_cells_mid_edge_nodes_on_its_chords():
    """A one-cell gmsh mesh whose edge (2, 3) bows past vertex 0: straightened, its Jacobian is constant again."""
    x = _tetrahedron(1.2)[0]
    gmsh_order = x[[0, 1, 2, 3, 9, 6, 8, 7, 4, 5]]  # basix's edges (0,1)->9 ... : the inverse of GMSH_TO_BASIX
    assert np.allclose(gmsh_order[list(curved.GMSH_TO_BASIX)], x)
    with compat.gmsh_session() as gmsh:
        gmsh.model.add("one")
        try:
            volume = gmsh.model.addDiscreteEntity(3)
            gmsh.model.mesh.addNodes(3, volume, list(range(1, 11)), gmsh_order.reshape(-1).tolist())
            gmsh.model.mesh.addElementsByType(volume, curved.GMSH_TETRAHEDRON10, [1], list(range(1, 11)))
            assert curved.straighten_folded_gmsh() == 1
            _, _, after = curved._gmsh_tetrahedra()
        finally:
            gmsh.model.remove()
    dets = curved.jacobian_dets(after, [(0.0, 0.0, 0.0), (0.25, 0.25, 0.25), (0.0, 0.5, 0.5)])
    assert np.allclose(dets, 1.0) and not curved.folded(after)[0]
