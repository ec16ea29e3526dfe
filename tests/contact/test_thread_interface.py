"""The sliding and frictionless thread, and what the interface passes to the tissue.

A sliding thread (``effects.thread_interface = "sliding"``) is bilateral and frictionless: the tissue's
side of the bare thread's track has its own nodes, held at r = r_t and free along it. Checked here:
the mesh split (the tissue and the thread share no node along the bare thread, the cones stay tied),
the load shares (they sum to the pull; a frictionless thread passes no axial force), the slip and
the track's gap against the thread's closed-form Poisson contraction, the lift it adds, 2 ranks equal
to serial, and the diagnosed stop of a sliding thread with nothing to hold it. A frictionless thread
the tissue may leave, and a Coulomb thread (friction_coefficient 0, 0.1, 0.5): the limits its lift must
respect (between tied and frictionless, growing as friction falls, frictionless at 0), its law, 2 ranks.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.conftest import FAST, cli, run_paper, sets
from tests.contact import split_mesh

#: One cone, P1, coarsest mesh, 1 N: the cheapest scene with a cone and a bare thread.
SCENE = [*FAST, "geometry.cones=1", "output.quantities=[\"usum\",\"interface\"]"]
SLIDING = [*SCENE, "effects.thread_interface=\"sliding\""]


_run = run_paper


@pytest.fixture(scope="module")
def tied(tmp_path_factory):
    return _run(tmp_path_factory, "tied", SCENE)


@pytest.fixture(scope="module")
def sliding(tmp_path_factory):
    return _run(tmp_path_factory, "sliding", SLIDING)


def test_the_split_mesh_shares_no_node_along_the_bare_thread_and_keeps_the_cones_tied():
    from suture_fem.geometry.regions import Facet

    tied, split = split_mesh(), split_mesh(split_thread=True)
    assert len(tied["thread"]) > 100 and int(Facet.TRACK) not in tied["groups"]
    assert int(Facet.TRACK) in split["groups"]
    assert split["cone"] == tied["cone"]  # the cones stay tied to the tissue
    # the only thread nodes the tissue still shares are where a cone meets the thread (tied to both)
    assert split["thread"] <= tied["cone"] and len(split["thread"]) == 2 * 2  # two junctions per hollow cone


@pytest.mark.parametrize("override, key", [('effects.thread_interface="glued"', "effects.thread_interface"),
                                           ("effects.friction_coefficient=2.5", "effects.friction_coefficient")])
def test_an_interface_model_or_coefficient_out_of_range_is_refused_in_one_line(override, key):
    proc = cli(["show", "paper", "--set", override])
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and key in lines[0], proc.stderr
    assert '"coulomb"' in lines[0] if key.endswith("interface") else "2" in lines[0]


def test_the_load_shares_sum_to_the_pull_and_the_tied_thread_carries_some(tied):
    rec = tied["at_forces"][-1]
    shares = rec["load_share_n"]
    assert list(shares) == ["cone_1", "thread"]
    assert sum(shares.values()) == pytest.approx(rec["force_n"], rel=1e-9)
    assert sum(shares.values()) == pytest.approx(-rec["reaction_force_n"], rel=1e-9)
    assert 0.05 < shares["thread"] < 0.95 and shares["cone_1"] > 0.05
    assert tied["effects"]["interfaces"]["thread"] == "tied"
    assert "slip_max_mm" not in rec["interface"]
    for name, prof in rec["interface"]["profiles"].items():
        assert prof["s_mm"] == sorted(prof["s_mm"]) and len(prof["s_mm"]) == len(prof["pressure_pa"]) > 5, name
        assert prof["axial_force_n"] == pytest.approx(shares[name], rel=1e-9)


def test_a_frictionless_sliding_thread_passes_no_axial_force_and_lifts_more(tied, sliding):
    rec, ref = sliding["at_forces"][-1], tied["at_forces"][-1]
    shares = rec["load_share_n"]
    assert abs(shares["thread"]) < 1e-9 * rec["force_n"]
    assert sum(shares.values()) == pytest.approx(rec["force_n"], rel=1e-9)
    assert shares["cone_1"] == pytest.approx(rec["force_n"], rel=1e-9)
    assert sliding["effects"]["interfaces"]["thread"] == "sliding"
    assert sliding["effects"]["interfaces"]["track_nodes"] > 50
    # the pull now goes through the cone alone: the thread end moves further (MODEL.md: about +9 % at 1 cone)
    assert 1.03 < rec["thread_end_displacement_mm"] / ref["thread_end_displacement_mm"] < 1.2


def test_the_slip_grows_toward_the_pull_and_the_thread_contracts_by_its_poisson_closed_form(sliding):
    rec = sliding["at_forces"][-1]
    thread = rec["interface"]["profiles"]["thread"]
    z = np.array(thread["z_mm"])
    slip = np.array([np.nan if v is None else v for v in thread["slip_mm"]])
    length = sliding["geometry"]["tissue_length_mm"]
    at_exit = slip[np.argmax(z)]
    assert at_exit == pytest.approx(rec["interface"]["slip_max_mm"], rel=1e-6)
    # the thread pulls the tissue along through the cone but never overtakes it: it slides toward the pull
    # everywhere along its track, least at the cone, most where it leaves the tissue
    assert np.nanmin(slip) > 0 and at_exit < rec["thread_end_displacement_mm"]
    assert np.isnan(slip[np.argmin(z)])  # the thread's far end has left the tissue's far face
    assert z.max() == pytest.approx(length)
    # closed form: the free thread (axial force F) contracts radially by nu F / (pi r_t E) (small strain);
    # the thread's strain at 1 N is 1.4 %, so the St Venant-Kirchhoff thread differs from it at that order
    scene = sliding["scene"]
    r_t = scene["geometry"]["thread_radius_mm"] * 1e-3
    svk = scene["materials"]["suture"]
    closed_mm = svk["poisson"] * rec["force_n"] / (math.pi * r_t * svk["young"]) * 1e3
    strain = rec["force_n"] / (math.pi * r_t**2 * svk["young"])
    assert rec["interface"]["thread_contraction_max_mm"] == pytest.approx(closed_mm, rel=strain)
    # a bilateral track never opens and is never entered
    assert rec["interface"]["separated_mm"] == [] and rec["interface"]["opening_max_mm"] == 0.0
    assert rec["interface"]["penetration_max_mm"] == 0.0


def test_two_ranks_give_the_serial_interface(tmp_path_factory, sliding):
    par = _run(tmp_path_factory, "sliding2", SLIDING, ranks=2)
    a, b = sliding["at_forces"][-1], par["at_forces"][-1]
    assert par["mpi_ranks"] == 2
    assert b["usum_mm"] == pytest.approx(a["usum_mm"], rel=1e-9)
    for name in a["load_share_n"]:
        assert b["load_share_n"][name] == pytest.approx(a["load_share_n"][name], rel=1e-9, abs=1e-12)
        pa, pb = a["interface"]["profiles"][name], b["interface"]["profiles"][name]
        assert pb["s_mm"] == pytest.approx(pa["s_mm"], abs=1e-12)
        scale = max(map(abs, pa["pressure_pa"]))
        assert pb["pressure_pa"] == pytest.approx(pa["pressure_pa"], rel=1e-6, abs=1e-6 * scale)
    assert b["interface"]["slip_max_mm"] == pytest.approx(a["interface"]["slip_max_mm"], rel=1e-6)


def test_a_sliding_thread_with_no_cone_stops_with_a_diagnosis(tmp_path):
    proc = cli(["run", "paper", *sets([*SLIDING, "geometry.cones=0"]), "--no-pictures", "--out", str(tmp_path)])
    assert proc.returncode == 3, proc.stderr
    assert "no_axial_support" in proc.stderr
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["status"] == "stopped" and res["diagnosis"]["cause"] == "no_axial_support"
    assert res["force_displacement"] == [[0.0, 0.0]]


@pytest.fixture(scope="module")
def unilateral(tmp_path_factory):
    return _run(tmp_path_factory, "frictionless", [*SCENE, "effects.thread_interface=\"frictionless\""])


def test_a_frictionless_thread_the_tissue_may_leave_opens_but_is_not_entered(sliding, unilateral):
    rec, bilateral = unilateral["at_forces"][-1], sliding["at_forces"][-1]
    assert unilateral["effects"]["interfaces"]["thread"] == "frictionless"
    shares = rec["load_share_n"]
    assert abs(shares["thread"]) < 1e-9 * rec["force_n"]
    assert sum(shares.values()) == pytest.approx(rec["force_n"], rel=1e-9)
    interface = rec["interface"]
    # where the bilateral track pulled the tissue inward, the tissue now leaves the thread
    assert min(bilateral["interface"]["profiles"]["thread"]["pressure_pa"]) < 0
    assert interface["separated_mm"] and interface["opening_max_mm"] > 0.01
    # unilateral: an open node carries no contact force; a closed one is pressed, never pulled
    thread = interface["profiles"]["thread"]
    gap, p = np.array(thread["gap_mm"]), np.array(thread["pressure_pa"])
    peak = np.max(np.abs(p))
    # the penalty law p = kappa x penetration at the most pressed node (its nodal pressure is a lumped average
    # of the law over its facets: measured 1.23 times the node's own value on this scene)
    kappa = unilateral["effects"]["interfaces"]["contact_penalty_pa_per_m"]
    k = int(np.argmax(p))
    assert gap[k] < 0 and p[k] == pytest.approx(kappa * -gap[k] * 1e-3, rel=0.5)
    # (an open node with open neighbours along z, and not next to a cone, whose tied junction with the thread
    # moves with the thread's contraction: there a facet shared with the cone's node may press)
    z, h = np.array(thread["z_mm"]), unilateral["scene"]["mesh"]["size_suture_mm"]
    near_cone = np.zeros(len(z), dtype=bool)
    for c in unilateral["geometry"]["cones"]:
        lo, hi = sorted((c["base_z_mm"], c["apex_z_mm"]))
        near_cone |= (z > lo - 2 * h) & (z < hi + 2 * h)
    open_run = (gap > 1e-4) & np.roll(gap > 1e-4, 1) & np.roll(gap > 1e-4, -1) & ~near_cone
    assert open_run.sum() > 5 and np.max(np.abs(p[open_run])) < 1e-9 * peak
    assert np.min(p) > -1e-9 * peak
    # fewer constraints than the bilateral track: the pulled end moves at least as far
    assert rec["thread_end_displacement_mm"] >= bilateral["thread_end_displacement_mm"] * (1 - 1e-9)


@pytest.mark.long  # one P2 ramp to 4 N, about 45 s; benchmarks/long_tests.py
def test_a_frictionless_thread_at_p2_carries_the_pull_to_4_n(tmp_path_factory, unilateral):
    """P2 thread contact: the energy's line search without the stall rule (it stopped at 1.82 N, docs/contact.md)."""
    res = _run(tmp_path_factory, "frictionless_p2",
               [*SCENE, "effects.thread_interface=\"frictionless\"", "mesh.degree=2", "loading.force_n=4"])
    assert res["status"] == "converged" and res["scene"]["mesh"]["degree"] == 2
    for rec in res["at_forces"]:
        shares = rec["load_share_n"]
        assert abs(shares["thread"]) < 1e-9 * rec["force_n"]
        assert sum(shares.values()) == pytest.approx(rec["force_n"], rel=1e-9)
        assert rec["free_residual_norm_n"] <= 1e-6 * rec["force_n"]
    assert res["at_forces"][-1]["force_n"] == pytest.approx(4.0)
    # the same scene at P1, 1 N: P2 locks less, so it lifts a little more (4.620 against 4.557 mm measured)
    p1, p2 = unilateral["at_forces"][-1], next(r for r in res["at_forces"] if r["force_n"] == pytest.approx(1.0))
    assert p1["usum_mm"] <= p2["usum_mm"] <= 1.05 * p1["usum_mm"]


def _coulomb(mu: float) -> list[str]:
    return [*SCENE, "effects.thread_interface=\"coulomb\"", f"effects.friction_coefficient={mu}"]


@pytest.fixture(scope="module")
def coulomb(tmp_path_factory):
    """Coulomb threads by friction coefficient."""
    return {mu: _run(tmp_path_factory, f"coulomb_{mu}", _coulomb(mu)) for mu in (0.0, 0.1, 0.5)}


def test_coulomb_friction_lifts_between_tied_and_frictionless_and_more_as_friction_falls(tied, unilateral, coulomb):
    usum = {mu: res["at_forces"][-1]["usum_mm"] for mu, res in coulomb.items()}
    tied_usum, frictionless_usum = tied["at_forces"][-1]["usum_mm"], unilateral["at_forces"][-1]["usum_mm"]
    # friction coefficient 0 is the frictionless thread: the same terms, zero
    assert usum[0.0] == pytest.approx(frictionless_usum, rel=1e-9)
    assert tied_usum < usum[0.5] < usum[0.1] < usum[0.0]
    thread = {mu: res["at_forces"][-1]["load_share_n"]["thread"] for mu, res in coulomb.items()}
    assert abs(thread[0.0]) < 1e-9 and 0.0 < thread[0.1] < thread[0.5]
    for res in coulomb.values():
        rec = res["at_forces"][-1]
        assert sum(rec["load_share_n"].values()) == pytest.approx(rec["force_n"], rel=1e-9)
        assert rec["free_residual_norm_n"] <= 1e-6 * rec["force_n"]  # the friction's forces counted


def test_coulomb_friction_obeys_its_law_where_the_tissue_touches_the_thread(coulomb):
    res = coulomb[0.5]
    interfaces = res["effects"]["interfaces"]
    assert interfaces["thread"] == "coulomb" and interfaces["friction_coefficient"] == 0.5
    friction = res["at_forces"][-1]["interface"]["friction"]
    assert friction["stick_nodes"] + friction["slip_nodes"] + friction["open_nodes"] == interfaces["friction_pairs"]
    assert friction["slip_nodes"] > 0 and friction["open_nodes"] > 0
    assert friction["coulomb_residual_n"] <= max(res["residual_floor_n"], 1e-10)
    # along the track the shear is at most mu times the pressure (nominal tractions)
    prof = res["at_forces"][-1]["interface"]["profiles"]["thread"]
    gap = np.array(prof["gap_mm"], dtype=float)
    track = gap != 0.0  # a tied node (a cone's junction) has no gap of its own
    shear = np.abs(np.array(prof["shear_pa"], dtype=float))[track]
    pressure = np.array(prof["pressure_pa"], dtype=float)[track]
    # the tractions' round-off: the residual's floor (N) over the smallest lumped area, pi r_t h (m^2)
    r_t, h = res["scene"]["geometry"]["thread_radius_mm"] * 1e-3, res["sizes_mm"]["suture"] * 1e-3
    noise = res["residual_floor_n"] / (math.pi * r_t * h)
    assert np.all(shear <= 0.5 * np.maximum(pressure, 0.0) * (1 + 1e-6) + noise)  # 1e-6: results.json's 7 digits
    assert np.any((shear > 0.49 * pressure) & (pressure > 1e3 * noise))  # some of it slides at the limit
    # none where nothing presses (an open node next to a closed facet still carries part of its pressure)
    assert np.all(shear[pressure <= noise] <= noise) and np.count_nonzero(pressure <= noise) > len(pressure) // 2


def test_two_ranks_give_the_serial_coulomb_thread(tmp_path_factory, coulomb):
    a = coulomb[0.5]["at_forces"][-1]
    b = _run(tmp_path_factory, "coulomb_2", _coulomb(0.5), ranks=2)["at_forces"][-1]
    assert b["usum_mm"] == pytest.approx(a["usum_mm"], rel=1e-7)
    for name in a["load_share_n"]:
        assert b["load_share_n"][name] == pytest.approx(a["load_share_n"][name], rel=1e-6, abs=1e-9)
    assert b["interface"]["friction"]["slip_nodes"] == a["interface"]["friction"]["slip_nodes"]
