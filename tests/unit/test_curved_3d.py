"""Quadratic tetrahedra (``mesh.geometry_degree = 2`` in 3-D): their mid-edge nodes lie on the model's curved
surfaces, the volume of the revolved section is then exact to the geometry's order, and a folded cell is found."""

from __future__ import annotations

import math

import dolfinx.fem
import numpy as np
import pytest
import ufl
from mpi4py import MPI

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
