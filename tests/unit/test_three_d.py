"""The 3-D model's pieces that need no solve: refusals before meshing, kinematics, stress measures, estimate."""

from __future__ import annotations

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from mpi4py import MPI

from suture_fem.geometry.estimate_3d import estimate_3d
from suture_fem.geometry.gmsh_model import MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.outputs.base import hencky_equivalent, von_mises
from suture_fem.physics import kinematics
from suture_fem.physics.three_d import check_three_d
from suture_fem.scene import Scene
from suture_fem.support import compat
from suture_fem.support.errors import SceneError

THREE_D = {"geometry.dimension": 3, "output.critical_distance_mm": 0.0, "output.quantities": ["usum", "seqv"]}


def test_a_plain_3d_scene_passes_the_checks():
    check_three_d(Scene.from_values(THREE_D))
    check_three_d(Scene.from_values({**THREE_D, "output.critical_distance_mm": 0.1}))  # the ball average is built
    built = {"output.fields": True, "loading.control": "displacement", "effects.inertia": True, "effects.gravity": True,
             "effects.suture": "rigid"}
    check_three_d(Scene.from_values({**THREE_D, **built}))  # and these, since 2026-12
    rounded_rims_frictionless_thread = {"geometry.cone_fillet_mm": 0.04, "effects.thread_interface": "frictionless"}
    check_three_d(Scene.from_values({**THREE_D, **rounded_rims_frictionless_thread}))
    for cones in ("sliding", "frictionless", "coulomb"):  # the unilateral ones since 2026-12-05
        check_three_d(Scene.from_values({**THREE_D, "effects.cone_interface": cones}))
    check_three_d(Scene.from_values({**THREE_D, "mesh.degree": 2, "mesh.geometry_degree": 2}))  # curved cells too


def test_the_slab_in_2d_is_refused():
    check_three_d(Scene.from_values({**THREE_D, "output.quantities": ["usum", "interface"]}))  # built in 3-D too
    with pytest.raises(SceneError, match="geometry.tissue_shape"):
        check_three_d(Scene.from_values({"geometry.tissue_shape": "slab"}))


SLAB = {**THREE_D, "geometry.tissue_shape": "slab"}


def test_a_plain_slab_passes_the_checks_and_keeps_the_thread_in_the_fat():
    scene = Scene.from_values({**SLAB, "output.quantities": ["usum", "dimple"]})
    check_three_d(scene)
    slab = Geometry.from_section(scene.geometry).slab
    g = scene.geometry
    assert slab.x_skin == g.thread_depth_mm and slab.x_deep == -g.hypodermis_mm
    assert slab.x_skin - slab.x_dermis == pytest.approx(g.epidermis_mm)
    assert slab.x_dermis - slab.x_hypodermis == pytest.approx(g.dermis_mm)
    assert slab.x_hypodermis > g.cone_base_diameter_mm / 2  # the cones lie below the dermis
    assert Geometry.from_section(Scene.from_values(THREE_D).geometry).slab is None


@pytest.mark.parametrize("values, key", [
    ({"geometry.thread_depth_mm": 0.5}, "geometry.thread_depth_mm"),  # outside the schema's 1-10 mm
    ({"geometry.thread_depth_mm": 11.0}, "geometry.thread_depth_mm"),
    ({"geometry.thread_depth_mm": 1.2}, "geometry.thread_depth_mm"),  # the cones (radius 0.635) reach the dermis
    ({"geometry.thread_depth_mm": 1.0, "geometry.cones": 0, "geometry.dermis_mm": 1.0}, "geometry.thread_depth_mm"),
    ({"geometry.slab_half_width_mm": 1.0}, "geometry.slab_half_width_mm"),
    ({"geometry.slab_half_width_mm": 2.0, "geometry.cone_base_diameter_mm": 4.0, "geometry.hypodermis_mm": 5.0,
      "geometry.thread_depth_mm": 4.0}, "geometry.slab_half_width_mm"),
])
def test_a_slab_that_does_not_hold_the_thread_in_the_fat_is_refused_in_one_line(values, key):
    with pytest.raises(SceneError) as err:
        Geometry.from_section(Scene.from_values({**SLAB, **values}).geometry)
    message = str(err.value)  # the schema's range ("expected ... >= 1 and <= 10") or the geometry's ("allowed ...")
    assert key in message and ("allowed" in message or "expected" in message) and "\n" not in message


def test_the_dimple_output_needs_the_slab():
    for values in ({**THREE_D}, {}):
        with pytest.raises(SceneError) as err:
            check_three_d(Scene.from_values({**values, "output.quantities": ["usum", "dimple"]}))
        assert "output.quantities" in str(err.value) and "tissue_shape" in str(err.value)


def test_the_slab_estimate_counts_its_block():
    # the default slab (half width 10 mm, 6.6 mm thick) holds more tissue than the cylinder (radius 3.6 mm)
    scene = Scene.from_values({**SLAB, "mesh.degree": 1})
    sizes = MeshSizes.from_section(scene.mesh)
    slab = estimate_3d(Geometry.from_section(scene.geometry), sizes, 1)
    cylinder = estimate_3d(Geometry.from_section(Scene.from_values({**THREE_D, "mesh.degree": 1}).geometry), sizes, 1)
    assert slab.cells > cylinder.cells > 0


def test_3d_deformation_gradient_and_half_model_weight():
    # u = A x, linear: F = I + A exactly; the weight 2 doubles the half model's volume
    A = np.array([[0.1, -0.2, 0.05], [0.3, 0.0, -0.1], [0.02, 0.4, -0.3]])
    mesh = dolfinx.mesh.create_unit_cube(MPI.COMM_SELF, 2, 2, 2)
    u = dolfinx.fem.Function(compat.vector_space(mesh, 1))
    u.interpolate(lambda x: A @ x)
    x = ufl.SpatialCoordinate(mesh)
    F = kinematics.deformation_gradient(u, x)
    for i in range(3):
        for j in range(3):
            value = dolfinx.fem.assemble_scalar(dolfinx.fem.form(F[i, j] * ufl.dx(domain=mesh)))
            assert value == pytest.approx(float(i == j) + A[i, j], abs=1e-12)
    vol = dolfinx.fem.assemble_scalar(dolfinx.fem.form(kinematics.volume_weight(x) * ufl.dx(domain=mesh)))
    assert vol == pytest.approx(2.0, rel=1e-12)


def test_3d_stress_measures_equal_the_axisymmetric_ones_on_an_axisymmetric_state():
    # (rr, zz, tt, rz) as the 3-D (xx, yy, zz, xy, yz, xz) of the same tensor, with the hoop direction as z
    rng = np.random.default_rng(1)
    s2 = rng.normal(size=(50, 4))
    s3 = np.column_stack([s2[:, 0], s2[:, 1], s2[:, 2], s2[:, 3], np.zeros(50), np.zeros(50)])
    np.testing.assert_allclose(von_mises(s3), von_mises(s2), rtol=1e-12)
    m = rng.normal(size=(50, 2, 2)) * 0.3 + np.eye(2)
    b2d = np.einsum("nij,nkj->nik", m, m)  # in-plane B = F F^T, positive definite
    hoop = rng.uniform(0.5, 1.5, size=50)
    b2 = np.column_stack([b2d[:, 0, 0], b2d[:, 1, 1], hoop, b2d[:, 0, 1]])
    b3 = np.column_stack([b2[:, 0], b2[:, 1], b2[:, 2], b2[:, 3], np.zeros(50), np.zeros(50)])
    for a, b in zip(hencky_equivalent(b3), hencky_equivalent(b2)):
        np.testing.assert_allclose(a, b, rtol=1e-10)


def test_the_3d_mesh_file_has_tetrahedra_and_the_symmetry_plane(tmp_path):
    from suture_fem.geometry.mesh import write_msh
    from suture_fem.scene.schema import GeometrySection, MeshSection

    record = write_msh(GeometrySection(dimension=3, cones=1),
                       MeshSection(size_suture_mm=0.6, size_rim_mm=0.2, size_far_mm=4.8), tmp_path / "m.msh")
    assert record["tetrahedra"] > 0 and "triangles" not in record
    text = (tmp_path / "m.msh").read_text()
    for name in ("symmetry", "outer", "interface", "pull_face", "hypodermis", "cone"):
        assert f'"{name}"' in text, name
