"""A coarse 3-D cylinder scene, solved: the half model balances the pull, agrees with the axisymmetric model
to its discretisation error, and the algebraic-multigrid solver finds the direct solver's state."""

from __future__ import annotations

import json

import pytest

from suture_fem.geometry.estimate_3d import estimate_3d
from suture_fem.geometry.gmsh_model import MeshSizes
from suture_fem.geometry.section import Geometry
from suture_fem.scene import Scene
from tests.conftest import cli, run_inprocess, sets

#: One full cone, coarse P1 tetrahedra (about 9,400 unknowns), 0.5 N with a report at 0.25 N: seconds.
COARSE = ["geometry.cones=1", 'geometry.cone_kind="full"', "mesh.degree=1", "mesh.size_suture_mm=0.5",
          "mesh.size_rim_mm=0.25", "mesh.size_far_mm=3.0", "geometry.margin_far_mm=1.5", "geometry.margin_pull_mm=1.5",
          "loading.force_n=0.5", "loading.report_forces_n=[0.25]", "output.critical_distance_mm=0",
          'output.quantities=["usum","seqv","eptoeqv","interface"]']
COARSE_3D = [*COARSE, "geometry.dimension=3"]
#: The same with the critical-distance ball (the whole tissue's search only: about 1 s a report here).
COARSE_3D_CD = [*COARSE_3D, "output.critical_distance_mm=0.1", "output.critical_distance_layers=false"]
#: The 3-D and 2-D models differ by their discretisations only: measured 2.5 % (USUM) and 1.7 % (energy)
#: on these coarse meshes, shrinking on the ladder of benchmarks/three_d.py.
COARSE_AGREEMENT = 0.05


@pytest.fixture(scope="module")
def three_d_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("three_d")
    run_inprocess("paper", [*COARSE_3D_CD, "output.fields=true"], folder)
    return folder


@pytest.fixture(scope="module")
def three_d(three_d_folder):
    return json.loads((three_d_folder / "results.json").read_text())


@pytest.mark.slow
def test_the_half_model_balances_the_whole_pull_and_says_it_is_a_half_model(three_d):
    assert three_d["status"] == "converged"
    assert three_d["model_3d"]["symmetry"].startswith("half model")
    for state in three_d["at_forces"]:
        # the polygonal end face's meshed area carries the traction: the whole force reaches the support
        assert state["reaction_force_n"] == pytest.approx(-state["force_n"], rel=1e-6)
        assert state["force_balance_rel"] < 1e-6
        assert len(state["usum_mm_at_mm"]) == 3
        assert state["regions"]["tissue"]["seqv_pa"] > 0


@pytest.mark.slow
def test_the_critical_distance_ball_is_reported_as_the_disc_is_in_2d(three_d):
    """The 2-D keys, a ball's centre (x, y, z) in the half model, an average no larger than the field's peak."""
    for state in three_d["at_forces"]:
        tissue = state["regions"]["tissue"]
        for name, peak in (("seqv_cd_pa", "seqv_pa"), ("eptoeqv_cd", "eptoeqv")):
            near = name.replace("_cd", "_cd_cone")
            assert 0 < tissue[near] <= tissue[name] <= tissue[peak]  # P1: an average of cell values, each a peak's
            assert state[name] == tissue[name] and state[name + "_region"] == "tissue"
            for key in (name, near):
                assert len(tissue[key + "_at_mm"]) == 3 and tissue[key + "_at_mm"][2] <= 0.0
        assert "ball of radius 0.1 mm" in state["where"]["seqv_cd_pa"]
        assert "seqv_cd_pa" not in state["regions"]["dermis"]  # output.critical_distance_layers = false


@pytest.mark.slow
def test_3d_agrees_with_the_axisymmetric_model(three_d, tmp_path):
    two_d = run_inprocess("paper", COARSE, tmp_path)
    assert [a["force_n"] for a in three_d["at_forces"]] == [b["force_n"] for b in two_d["at_forces"]]
    for a, b in zip(three_d["at_forces"], two_d["at_forces"]):
        for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j"):
            assert a[q] == pytest.approx(b[q], rel=COARSE_AGREEMENT), q
        # the load shares: the half model's interface forces (axial, in the meridian plane) sum to the whole pull,
        # split between the cone and the thread as the axisymmetric model splits it (measured 0.9 % of the pull)
        assert sum(a["load_share_n"].values()) == pytest.approx(a["force_n"], rel=1e-6)
        for part, share in a["load_share_n"].items():
            assert share > 0 and abs(share - b["load_share_n"][part]) < COARSE_AGREEMENT * a["force_n"], part
        cone = a["interface"]["profiles"]["cone_1"]
        assert len(cone["s_mm"]) == len(cone["pressure_pa"]) > len(b["interface"]["profiles"]["cone_1"]["s_mm"])


@pytest.mark.slow
def test_gamg_finds_the_direct_solvers_state(three_d, tmp_path):
    # to the first reported force only (the same equilibrium, whatever the ramp), to keep it short
    gamg = run_inprocess("paper", [*COARSE_3D, 'solver.linear_method="gamg"', "loading.force_n=0.25",
                                   "loading.report_forces_n=[]"], tmp_path)
    assert gamg["linear_solver"] == "gamg" and gamg["linear_solver_fallbacks"] == []
    a, b = three_d["at_forces"][0], gamg["at_forces"][0]
    assert a["force_n"] == b["force_n"] == 0.25
    for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j", "seqv_pa"):
        assert b[q] == pytest.approx(a[q], rel=1e-6), q


@pytest.mark.slow
def test_the_estimate_before_meshing_is_near_gmshs_count(three_d):
    values = dict(_parse(s) for s in COARSE_3D)
    scene = Scene.from_values(values)
    found = estimate_3d(Geometry.from_section(scene.geometry), MeshSizes.from_section(scene.mesh), 1)
    assert 0.5 < found.cells / three_d["cells"] < 2.0


def _parse(text: str) -> tuple[str, object]:
    import tomllib

    key, value = text.split("=", 1)
    return key, tomllib.loads(f"v = {value}")["v"]


def test_the_mesh_command_writes_the_3d_half_model(tmp_path):
    out = tmp_path / "three_d.msh"
    keys = ["geometry.dimension=3", "geometry.cones=1", "mesh.size_suture_mm=0.6", "mesh.size_rim_mm=0.2",
            "mesh.size_far_mm=4.8", "output.critical_distance_mm=0", 'output.quantities=["usum"]']
    proc = cli(["mesh", "paper", *sets(keys), "--out", str(out)])
    assert proc.returncode == 0, proc.stderr
    record = json.loads(out.with_suffix(".json").read_text())
    assert record["tetrahedra"] > 0 and f"({record['tetrahedra']} tetrahedra)" in proc.stdout
    assert record["thread_track_split"] is False and "cone_surfaces_split" not in record


@pytest.mark.slow
def test_the_field_files_hold_the_3d_displacement_and_stress(three_d, three_d_folder):
    # read as XML (VTK's XDMF reader, pyvista.get_reader, crashed the process on Debian 13; on Debian 12 it read
    # the displacement's largest norm as USUM and the stress's largest value as SEQV, to single precision)
    from xml.etree import ElementTree

    root = ElementTree.parse(three_d_folder / "fields.xdmf").getroot()
    assert {t.get("TopologyType") for t in root.iter("Topology")} == {"Tetrahedron"}
    nodes = three_d["dofs"] // 3  # P1: three displacement components per node
    wanted = {"displacement_m": f"{nodes} 3", "von_mises_pa": f"{three_d['cells']} 1"}
    for name, dims in wanted.items():
        grids = [g for g in root.iter("Grid") if g.find(f"Attribute[@Name='{name}']") is not None]
        assert [float(g.find("Time").get("Value")) for g in grids] == [a["force_n"] for a in three_d["at_forces"]]
        assert {g.find("Attribute/DataItem").get("Dimensions") for g in grids} == {dims}, name
    assert (three_d_folder / "fields.h5").stat().st_size > 8 * len(three_d["at_forces"]) * 4 * nodes


@pytest.mark.slow
def test_moving_the_3d_end_where_the_force_took_it_takes_that_force(three_d, tmp_path):
    end = three_d["thread_end_displacement_mm"]
    moved = run_inprocess("paper", [*COARSE_3D, 'loading.control="displacement"', f"loading.displacement_mm={end!r}",
                                    "loading.report_displacements_mm=[]"], tmp_path)
    assert moved["control"] == "displacement" and moved["status"] == "converged"
    rec = moved["at_forces"][-1]
    assert rec["force_n"] == pytest.approx(three_d["at_forces"][-1]["force_n"], rel=1e-6)  # the half model's reaction
    assert moved["thread_end_displacement_mm"] == pytest.approx(end, rel=1e-12)
    # the moved end face stays flat at d, the pulled one (a uniform traction) bulges: its largest displacement, USUM,
    # is above its mean, the end's displacement, by 2.5e-5 mm here; the two lifts differ by less
    assert abs(moved["usum_mm"] - three_d["usum_mm"]) < three_d["usum_mm"] - end
    assert rec["force_balance_rel"] < 1e-6


@pytest.mark.slow
def test_gravity_in_3d_weighs_what_the_axisymmetric_model_weighs_and_balances(tmp_path):
    heavy = ["effects.gravity=true"]
    three = run_inprocess("paper", [*COARSE_3D, *heavy], tmp_path / "3d")
    two = run_inprocess("paper", [*COARSE, *heavy], tmp_path / "2d")
    weight = three["effects"]["gravity"]["weight_n"]
    # twice the half model's tetrahedra against the exact solid of revolution of the 2-D cells: polygonal surfaces
    assert weight == pytest.approx(two["effects"]["gravity"]["weight_n"], rel=0.01)  # measured 0.23 % apart
    F = three["applied_force_n"]
    assert abs(three["reaction_force_n"] + F - weight) < 1e-6 * F  # the outer surface holds the pull less the weight


@pytest.mark.long  # about a minute of CPU: benchmarks/long_tests.py runs it
def test_a_damped_3d_hold_settles_on_the_quasi_static_answer(three_d, tmp_path):
    dynamic = run_inprocess("paper", [*COARSE_3D, "effects.inertia=true", "loading.ramp_s=0.02", "loading.hold_s=0.1",
                                      "effects.time_step_s=0.004", "effects.rayleigh_mass_per_s=400",
                                      "effects.rayleigh_stiffness_s=1e-4"], tmp_path)
    assert dynamic["effects"]["hold"]["solved"] is True
    assert dynamic["usum_mm"] == pytest.approx(three_d["usum_mm"], rel=0.01)  # measured -0.08 %


@pytest.mark.slow
def test_the_rigid_suture_in_3d_moves_as_one_and_shortens_the_pull(three_d, tmp_path):
    rigid = run_inprocess("paper", [*COARSE_3D, 'effects.suture="rigid"'], tmp_path)
    assert rigid["effects"]["suture"]["rigid_unknowns"] == 1  # the suture's three components replaced by one motion
    F = rigid["applied_force_n"]
    assert rigid["reaction_force_n"] == pytest.approx(-F, rel=1e-6)
    # without the thread's stretch the end moves less, by about the free thread's F L / (E A)
    assert 0.99 * three_d["thread_end_displacement_mm"] < rigid["thread_end_displacement_mm"] \
        < three_d["thread_end_displacement_mm"]


@pytest.mark.long  # about ten minutes of CPU (P2 tetrahedra, 69,000 unknowns): benchmarks/long_tests.py runs it
def test_the_mixed_formulation_in_3d_agrees_with_the_axisymmetric_one(tmp_path):
    mixed = ["mesh.degree=2", 'effects.incompressibility="mixed"']
    three = run_inprocess("paper", [*COARSE_3D, *mixed], tmp_path / "3d")
    two = run_inprocess("paper", [*COARSE, *mixed], tmp_path / "2d")
    assert three["status"] == "converged" and three["at_forces"][-1]["force_balance_rel"] < 1e-6
    for q in ("usum_mm", "strain_energy_j"):  # measured 0.11 % and 1.3 % apart
        assert three[q] == pytest.approx(two[q], rel=COARSE_AGREEMENT), q


@pytest.mark.long  # about three minutes of CPU (P2 tetrahedra twice): benchmarks/long_tests.py runs it
def test_curved_tetrahedra_solve_the_same_model_as_straight_ones(tmp_path):
    """Quadratic (curved) cells change the geometry's faceting only: the same answer to a fraction of the 3-D-to-2-D
    gap, and the pull balanced."""
    p2 = ["mesh.degree=2", "loading.force_n=0.1", "loading.report_forces_n=[]"]
    # measured: curved against straight -0.08 % (USUM) and -0.15 % (energy); straight against 2-D +0.63 % and +0.11 %,
    # curved against 2-D +0.55 % and -0.04 %
    agreement = 0.005
    straight = run_inprocess("paper", [*COARSE_3D, *p2], tmp_path / "straight")
    curved = run_inprocess("paper", [*COARSE_3D, *p2, "mesh.geometry_degree=2"], tmp_path / "curved")
    two = run_inprocess("paper", [*COARSE, *p2], tmp_path / "2d")
    assert (straight["geometry_degree"], curved["geometry_degree"]) == (1, 2)
    assert curved["status"] == "converged" and curved["model_3d"]["cells"].startswith("quadratic tetrahedra")
    assert curved["reaction_force_n"] == pytest.approx(-0.1, rel=1e-6) and curved["force_balance_rel"] < 1e-6
    for q in ("usum_mm", "strain_energy_j"):
        gap = abs(straight[q] / two[q] - 1.0)
        assert abs(curved[q] / straight[q] - 1.0) < agreement, q
        assert abs(curved[q] / two[q] - 1.0) < gap + agreement, q

