"""A coarse 3-D slab, solved: the half model balances the pull, the skin's normal displacement and the dimple
over the cone are reported per force, and the mesh estimate knows the slab's size."""

from __future__ import annotations

import json

import pytest

from suture_fem.geometry.estimate_3d import estimate_3d
from suture_fem.geometry.gmsh_model import MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.scene import Scene
from tests.conftest import run_inprocess
from tests.integration.test_three_d_run import COARSE_3D

#: The coarse 3-D cylinder scene as a slab, with the skin's outputs.
COARSE_SLAB = [*COARSE_3D, 'geometry.tissue_shape="slab"', 'output.quantities=["usum","seqv","eptoeqv","dimple"]']


@pytest.fixture(scope="module")
def slab_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("slab")
    run_inprocess("paper", COARSE_SLAB, out)  # with the pictures
    return out


@pytest.fixture(scope="module")
def slab(slab_out):
    return json.loads((slab_out / "results.json").read_text())


@pytest.mark.slow
def test_the_slab_draws_its_skin_and_its_cut_and_prints_its_dimples(slab_out, slab):
    from suture_fem.cli.run_report import summary

    for name in ("skin.png", "cut.png", "force_displacement.png"):
        assert (slab_out / name).stat().st_size > 10_000, name
    printed = summary(slab, slab_out, [])
    for state in slab["at_forces"]:
        relief = f"(under a straightedge: {state['dimple_relief_mm'][0]:.3g})"
        assert f"dimple over each cone {state['dimple_depth_mm'][0]:.3g} {relief};" in printed


@pytest.mark.slow
def test_the_slab_balances_the_pull_and_says_it_is_a_half_slab(slab):
    assert slab["status"] == "converged"
    assert slab["model_3d"]["tissue_shape"] == "slab" and slab["model_3d"]["symmetry"].startswith("half model")
    assert slab["geometry"]["slab"]["thread_depth_mm"] == slab["scene"]["geometry"]["thread_depth_mm"]
    for state in slab["at_forces"]:
        assert state["reaction_force_n"] == pytest.approx(-state["force_n"], rel=1e-6)
        assert state["force_balance_rel"] < 1e-6


@pytest.mark.slow
def test_the_skin_outputs_cover_the_skin_and_each_cone(slab):
    depth = slab["scene"]["geometry"]["thread_depth_mm"]
    length = slab["geometry"]["tissue_length_mm"]
    cones = slab["geometry"]["cones"]
    for state in slab["at_forces"]:
        assert len(state["dimple_depth_mm"]) == len(cones) == 1
        for value, at, cone in zip(state["dimple_depth_mm"], state["dimple_depth_at_mm"], cones):
            assert value <= state["skin_inward_mm"]  # the whole skin's largest inward displacement bounds each cone's
            assert at[0] == pytest.approx(depth) and abs(at[2]) <= depth * (1 + 1e-9)  # on the skin, over the thread
            assert min(cone["base_z_mm"], cone["apex_z_mm"]) <= at[1] <= max(cone["base_z_mm"], cone["apex_z_mm"])
        profile = state["skin_profile_mm"]
        assert len(state["dimple_relief_mm"]) == len(state["dimple_relief_at_y_mm"]) == 1
        span = sorted((cones[0]["base_z_mm"], cones[0]["apex_z_mm"]))
        assert span[0] - depth <= state["dimple_relief_at_y_mm"][0] <= span[1] + depth  # the straightedge's window
        ys = [y for y, _ in profile]
        assert ys == sorted(ys) and ys[0] == pytest.approx(0.0, abs=1e-9) and ys[-1] == pytest.approx(length)
        normals = [un for _, un in profile]
        assert max(normals) <= state["skin_outward_mm"] and -min(normals) <= state["skin_inward_mm"]
    # the pull moves the skin more at the larger force
    assert slab["at_forces"][1]["skin_inward_mm"] > slab["at_forces"][0]["skin_inward_mm"] > 0


@pytest.mark.slow
def test_the_slab_estimate_is_within_a_factor_two_of_gmsh(slab):
    scene = Scene.from_values({"geometry.dimension": 3, "geometry.tissue_shape": "slab", "geometry.cones": 1,
                               "geometry.cone_kind": "full", "mesh.degree": 1, "mesh.size_suture_mm": 0.5,
                               "mesh.size_rim_mm": 0.25, "mesh.size_far_mm": 3.0, "geometry.margin_far_mm": 1.5,
                               "geometry.margin_pull_mm": 1.5})
    found = estimate_3d(Geometry.from_section(scene.geometry), MeshSizes.from_section(scene.mesh), 1)
    assert 0.5 < found.cells / slab["cells"] < 2.0
