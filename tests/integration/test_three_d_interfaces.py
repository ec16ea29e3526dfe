"""The 3-D half model with rounded rims and with the thread in its own track, against the axisymmetric model on
the coarse scene of test_three_d_run.py (one full cone, P1, 0.5 N)."""

from __future__ import annotations

import json

import pytest

from tests.conftest import cli, run_inprocess, sets
from tests.integration.test_three_d_run import COARSE, COARSE_3D, COARSE_AGREEMENT

ROUNDED = ["geometry.cone_fillet_mm=0.05"]
#: The fillet's lift of USUM, 3-D against 2-D (percentage points). Each is the difference of two runs with the
#: same discretisation error (3-D 2.5 % below 2-D on these sizes), which mostly cancels: measured 1.32 against
#: 1.35 % (0.03 points apart); a fifth of that discretisation error allowed.
FILLET_LIFT_AGREEMENT = 0.005


@pytest.mark.long  # 72 s: the rounded rims' 37,098 dofs (benchmarks/long_tests.py)
def test_rounded_rims_in_3d_lift_as_much_as_in_2d(tmp_path):
    cases = (("3d", COARSE_3D), ("3d_rounded", [*COARSE_3D, *ROUNDED]), ("2d", COARSE),
             ("2d_rounded", [*COARSE, *ROUNDED]))
    runs = {name: run_inprocess("paper", values, tmp_path / name) for name, values in cases}
    assert runs["3d_rounded"]["status"] == "converged"
    final = {name: run["at_forces"][-1] for name, run in runs.items()}
    assert final["3d_rounded"]["reaction_force_n"] == pytest.approx(-final["3d_rounded"]["force_n"], rel=1e-6)
    usum = {name: state["usum_mm"] for name, state in final.items()}
    assert usum["3d_rounded"] == pytest.approx(usum["2d_rounded"], rel=COARSE_AGREEMENT)
    lift_3d, lift_2d = usum["3d_rounded"] / usum["3d"] - 1, usum["2d_rounded"] / usum["2d"] - 1
    assert lift_3d > 0 and abs(lift_3d - lift_2d) < FILLET_LIFT_AGREEMENT
    # the rounded rims' own peaks are found in 3-D too, at a point (x, y, z) near a fillet arc
    tissue = final["3d_rounded"]["regions"]["tissue"]
    assert tissue["seqv_fillet_pa"] > 0 and len(tissue["seqv_fillet_pa_at_mm"]) == 3


@pytest.mark.slow
@pytest.mark.parametrize("model", ["frictionless", "sliding"])
def test_a_thread_in_its_own_track_in_3d_agrees_with_the_axisymmetric_one(tmp_path, model):
    """The tissue's own nodes on the track: the cone carries the whole pull, as in 2-D.

    Frictionless, the penalty on u . e_r; sliding, u . e_r = 0 through the solver's reduction. Measured: USUM 2.66 %
    (frictionless) and 2.34 % (sliding) below 2-D, where tied is 2.45 % below; the thread's share 0 to 1e-13 N.
    Frictionless, the tissue opens off the track (0.21 mm; 2-D 0.27 mm) and sinks into it by the penalty's
    penetration (12 um; 2-D 17 um); sliding, it stays on it (3e-18 mm).
    """
    interface = [f'effects.thread_interface="{model}"']
    three, two = (run_inprocess("paper", [*values, *interface], tmp_path / name)
                  for name, values in (("3d", COARSE_3D), ("2d", COARSE)))
    assert three["status"] == "converged"
    for a, b in zip(three["at_forces"], two["at_forces"]):
        assert a["reaction_force_n"] == pytest.approx(-a["force_n"], rel=1e-6)
        for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j"):
            assert a[q] == pytest.approx(b[q], rel=COARSE_AGREEMENT), q
        assert abs(a["load_share_n"]["thread"]) < 1e-9 * a["force_n"]
        assert a["load_share_n"]["cone_1"] == pytest.approx(a["force_n"], rel=1e-6)
        assert a["interface"]["thread"] == model
        if model == "frictionless":
            assert a["interface"]["opening_max_mm"] > 0 and 0 < a["interface"]["penetration_max_mm"] < 0.05
        else:
            assert max(a["interface"]["opening_max_mm"], a["interface"]["penetration_max_mm"]) < 1e-12


@pytest.mark.parametrize("model", ["frictionless", "sliding", "coulomb"])
def test_a_thread_in_its_own_track_without_cones_stops_in_3d_as_in_2d(tmp_path, model):
    interface = [f'effects.thread_interface="{model}"']
    proc = cli(["run", "paper", *sets([*COARSE_3D, *interface, "geometry.cones=0"]), "--no-pictures",
                "--out", str(tmp_path)])
    assert proc.returncode == 3 and "no_axial_support" in proc.stderr, proc.stderr
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["status"] == "stopped" and res["diagnosis"]["cause"] == "no_axial_support"


COULOMB = ['effects.thread_interface="coulomb"']


def _coulomb_runs(tmp_path, mu):
    values = [*COULOMB, f"effects.friction_coefficient={mu}"]
    return {name: run_inprocess("paper", [*base, *values], tmp_path / name)
            for name, base in (("3d", COARSE_3D), ("2d", COARSE))}


@pytest.mark.slow
def test_a_coulomb_thread_in_3d_agrees_with_the_axisymmetric_one(tmp_path):
    """Mu 0.3: the frictionless thread's penalty on u . e_r, the friction on u_y node to node.

    Measured at 0.5 N: USUM 2.66 % and the energy 2.21 % below 2-D (tied: 2.45 % and 1.71 %). The tissue touches the
    thread over less than one track element behind the cone (2-D: 2 of 10 track nodes, 3-D: 27 of 373), so the
    thread's share (its friction) is resolved by a node or two: 1.89 mN in 3-D, 3.18 mN in 2-D, both under 1 % of
    the pull and far below the tied thread's 67 / 62 mN.
    """
    runs = _coulomb_runs(tmp_path, 0.3)
    assert runs["3d"]["status"] == "converged"
    for a, b in zip(runs["3d"]["at_forces"], runs["2d"]["at_forces"]):
        assert a["reaction_force_n"] == pytest.approx(-a["force_n"], rel=1e-6)
        for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j"):
            assert a[q] == pytest.approx(b[q], rel=COARSE_AGREEMENT), q
        assert a["interface"]["thread"] == "coulomb"
        friction = a["interface"]["friction"]
        assert friction["stick_nodes"] + friction["slip_nodes"] > 0 and friction["coulomb_residual_n"] < 1e-9
        assert 0 < a["load_share_n"]["thread"] < 0.01 * a["force_n"]
        assert 0 < b["load_share_n"]["thread"] < 0.01 * b["force_n"]
        assert a["load_share_n"]["thread"] + a["load_share_n"]["cone_1"] == pytest.approx(a["force_n"], rel=1e-6)
    # where the output finds a slip of 0.34 mm (two nodes, one above 1 kPa), shear = mu pressure by its own tractions
    # (0.27-0.34 at the closed nodes it gives no slip for; its normal is the facets' average, not e_r; not investigated)
    profile = runs["3d"]["at_forces"][-1]["interface"]["profiles"]["thread"]
    slipping = [s / p for p, s, g in zip(profile["pressure_pa"], profile["shear_pa"], profile["slip_mm"])
                if p and p > 1e3 and g is not None and g > 0.1]
    assert slipping and all(ratio == pytest.approx(0.3, rel=0.01) for ratio in slipping)


@pytest.mark.long  # 72 s: 3-D mu 2 (42 s CPU), mu 0.3 and tied (benchmarks/long_tests.py)
def test_a_large_friction_coefficient_in_3d_moves_load_to_the_thread_as_in_2d(tmp_path):
    """Mu 2 against mu 0.3: the thread's share rises (3-D 1.89 -> 6.00 mN, 2-D 3.18 -> 7.18 mN), nodes stick, and
    stays below the tied thread's (67 mN in 3-D): only the closed part of the track carries friction."""
    runs = _coulomb_runs(tmp_path, 2.0)
    low = _coulomb_runs(tmp_path / "low", 0.3)
    tied = run_inprocess("paper", COARSE_3D, tmp_path / "tied")["at_forces"][-1]["load_share_n"]["thread"]
    for name in ("3d", "2d"):
        share = runs[name]["at_forces"][-1]["load_share_n"]["thread"]
        assert low[name]["at_forces"][-1]["load_share_n"]["thread"] < share < tied
    assert runs["3d"]["at_forces"][-1]["interface"]["friction"]["stick_nodes"] > 0
    for q in ("usum_mm", "strain_energy_j"):
        a, b = (runs[n]["at_forces"][-1][q] for n in ("3d", "2d"))
        assert a == pytest.approx(b, rel=COARSE_AGREEMENT), q


#: How far the 3-D cones' interface models may sit from the tied model's 3-D-against-2-D gap (points of USUM): the
#: gaps are discretisation errors of the same meshes; measured (sliding, 0.25 and 0.5 N) 0.54 and 0.25 points on
#: Debian 12's gmsh 4.8 meshes, 1.10 and 0.48 on Debian 13's gmsh 4.13 ones, where the sliding gap is the same
#: (-2.99 / -2.71 % against -2.97 / -2.70 %) and the tied gap is not (-1.89 / -2.23 % against -2.43 / -2.45 %):
#: the tied reference's own gap moves 0.54 points with the mesh generator. The band was 1 point, set on Debian 12.
CONE_GAP_AGREEMENT = 0.015


@pytest.mark.slow
def test_sliding_cones_in_3d_agree_with_the_axisymmetric_ones(tmp_path):
    """The tissue's own nodes on the cone, held on its surface and free along it (a bilateral penalty).

    Measured at 0.25 and 0.5 N: USUM 2.97 % and 2.70 % below 2-D, where the tied model is 2.43 % and 2.45 % below;
    the cone's share 0.167 / 0.328 N against 2-D's 0.161 / 0.323 N; every pair slipping, as in 2-D.
    """
    cones = ['effects.cone_interface="sliding"']
    runs = {name: run_inprocess("paper", values, tmp_path / name)
            for name, values in (("3d", [*COARSE_3D, *cones]), ("2d", [*COARSE, *cones]), ("3d_tied", COARSE_3D),
                                 ("2d_tied", COARSE))}
    assert runs["3d"]["status"] == "converged"
    for a, b, ta, tb in zip(*(runs[n]["at_forces"] for n in ("3d", "2d", "3d_tied", "2d_tied"))):
        force = a["force_n"]
        assert a["reaction_force_n"] == pytest.approx(-force, rel=1e-6)
        for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j"):
            assert a[q] == pytest.approx(b[q], rel=COARSE_AGREEMENT), q
        gap, tied_gap = a["usum_mm"] / b["usum_mm"] - 1, ta["usum_mm"] / tb["usum_mm"] - 1
        assert abs(gap - tied_gap) < CONE_GAP_AGREEMENT
        assert sum(a["load_share_n"].values()) == pytest.approx(force, rel=1e-9)
        assert a["load_share_n"]["cone_1"] == pytest.approx(b["load_share_n"]["cone_1"], abs=COARSE_AGREEMENT * force)
        contact = a["interface"]["cone_contact"]
        assert a["interface"]["cones"] == contact["model"] == "sliding"
        assert contact["slip_nodes"] > 100 and contact["open_nodes"] == 0  # bilateral: every pair held, sliding
        assert contact["cones"]["cone_1"]["slip_max_mm"] == pytest.approx(
            b["interface"]["cone_contact"]["cones"]["cone_1"]["slip_max_mm"], rel=0.1)


@pytest.mark.long  # four ramps, about 4 CPU minutes (benchmarks/long_tests.py)
def test_unilateral_cones_in_3d_agree_with_the_axisymmetric_ones(tmp_path):
    """Frictionless and Coulomb (mu 0.3) cones in 3-D, by the trust region and the swapping pairs' doubled penalty.

    Measured at 0.25 / 0.5 N against 2-D on the same sizes: USUM -3.8 / -3.7 % (frictionless) and -4.3 / -4.1 %
    (Coulomb), where tied is -2.4 %; the cone's share 0.062 / 0.108 N against 0.053 / 0.103 N (frictionless) and
    0.089 / 0.149 against 0.063 / 0.119 N (Coulomb): the coarse facets of the 3-D cone hold more (docs/three-d.md,
    "The unilateral cones"). Before, the frictionless cones stopped at 0.21 of 0.5 N here.
    """
    runs = {(model, dim): run_inprocess("paper", [*values, f'effects.cone_interface="{model}"'],
                                        tmp_path / f"{model}_{dim}")
            for model in ("frictionless", "coulomb") for dim, values in (("3d", COARSE_3D), ("2d", COARSE))}
    for model in ("frictionless", "coulomb"):
        three, two = runs[model, "3d"], runs[model, "2d"]
        assert three["status"] == "converged" and three["trust_region"]["converged"] >= 1
        for a, b in zip(three["at_forces"], two["at_forces"], strict=True):
            force = a["force_n"]
            assert a["reaction_force_n"] == pytest.approx(-force, rel=1e-6)
            for q in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j"):
                assert a[q] == pytest.approx(b[q], rel=COARSE_AGREEMENT), (model, force, q)
            assert sum(a["load_share_n"].values()) == pytest.approx(force, rel=1e-9)
            contact = a["interface"]["cone_contact"]
            assert a["interface"]["cones"] == contact["model"] == model
            assert contact["open_nodes"] > 0 and contact["slip_nodes"] > 0  # the tissue leaves the cone, and slides
    for three_or_two in ("3d", "2d"):  # friction holds more on the cone than none, in 3-D as in 2-D
        for a, b in zip(runs["coulomb", three_or_two]["at_forces"], runs["frictionless", three_or_two]["at_forces"]):
            assert a["load_share_n"]["cone_1"] > b["load_share_n"]["cone_1"] > 0.0
