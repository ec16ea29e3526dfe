"""The accuracy-cost ledger and `run --error-estimate`: Richardson arithmetic, files, the CLI contract."""

from __future__ import annotations

import json
import math

import pytest

from suture_fem.studies.convergence.quantities import QUANTITIES
from suture_fem.studies.convergence.richardson import richardson, two_rung_error
from tests.conftest import FAST, sets


@pytest.mark.parametrize("order", [1.0, 2.0, 0.7])
def test_richardson_recovers_order_and_limit_of_a_power_law(order):
    values = [3.0 + 0.5 * h**order for h in (1.0, 0.5, 0.25)]
    est = richardson(values)
    assert est.verdict == "converging"
    assert est.order == pytest.approx(order, rel=1e-12)
    assert est.limit == pytest.approx(3.0, rel=1e-12)


def test_richardson_calls_a_growing_or_oscillating_sequence_what_it_is():
    singular = [2.0 * h**-0.3 for h in (1.0, 0.5, 0.25)]  # a stress singularity sampled at h
    assert richardson(singular).verdict == "diverging" and richardson(singular).limit is None
    assert richardson([1.0, 1.2, 1.1]).verdict == "oscillating"
    assert richardson([1.0, 1.2]).verdict == "too few rungs"
    settled = richardson([1.0, 1.0005, 1.0003], settled_rel=1e-3)
    assert settled.verdict == "settled" and settled.limit == 1.0003 and settled.correction == pytest.approx(2e-4)


def test_a_quantity_with_a_tolerance_settles_only_when_the_richardson_estimate_agrees():
    # second order, last change 0.4 % and correction 0.13 %: settled with the extrapolated limit
    est = richardson([1.0, 0.984, 0.98], tolerance=0.02)
    assert est.verdict == "settled" and est.order == pytest.approx(2.0)
    assert est.limit == pytest.approx(0.98 - 0.004 / 3)
    assert richardson([1.0, 0.984, 0.98]).verdict == "converging"  # without the tolerance
    assert richardson([1.0, 0.9, 0.885], tolerance=0.02).verdict == "settled"  # a first change of 10 % is allowed
    # last change 1.9 %, order 0.6: the correction (3.1 %) is outside the tolerance
    assert richardson([1.0, 0.9713, 0.9524], tolerance=0.02, min_order=0.5).verdict == "converging"
    # changes within 2 % that do not shrink: no limit in sight, whatever the tolerance
    assert richardson([1.0, 0.985, 0.97], tolerance=0.02, min_order=0.5).verdict == "diverging"
    # an oscillation settles when its last change is within 2 % and shrinks (uncertainty: that change)
    shrinking = richardson([1.0, 1.05, 1.045], tolerance=0.02)
    assert shrinking.verdict == "settled" and shrinking.limit == 1.045 and shrinking.correction == pytest.approx(0.005)
    # a growing oscillation settles only while both changes are within 2 % (uncertainty: the larger)
    wobble = richardson([1.0, 1.005, 0.99], tolerance=0.02)
    assert wobble.verdict == "settled" and wobble.correction == pytest.approx(0.015)
    assert richardson([1.0, 1.005, 0.97], tolerance=0.02).verdict == "oscillating"  # last change 3.6 %
    assert richardson([1.0, 1.05, 1.02], tolerance=0.02).verdict == "oscillating"  # last change 3 %


def test_the_stress_measures_carry_the_issues_two_percent_and_usum_the_noise_floor_only():
    tolerance = {q.path: q.tolerance for q in QUANTITIES}
    assert tolerance["usum_mm"] == 0.0 and tolerance["regions.tissue.seqv_pa"] == 0.0
    for path in ("seqv_fillet_pa", "eptoeqv_fillet", "seqv_cd_pa", "eptoeqv_cd"):
        assert tolerance["regions.tissue." + path] == 0.02


def test_two_rung_error_is_the_difference_over_two_to_the_p_minus_one():
    assert two_rung_error(4.1, 4.0, order=1.0) == pytest.approx(0.1)
    assert two_rung_error(4.1, 4.0, order=2.0) == pytest.approx(0.1 / 3)


def test_run_error_estimate_attaches_plus_minus(tmp_path):
    from suture_fem.cli import main

    out = tmp_path / "run"
    # sharp rims (the default rounds the base rims, and the peak then sits on the resolved fillet)
    scene = FAST + ["geometry.cones=1", "geometry.cone_fillet_mm=0"]
    assert main(["run", "paper", *sets(scene), "--error-estimate", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    est = res["error_estimate"]
    usum = est["at_forces"][-1]["usum_mm"]
    assert usum["value"] == res["usum_mm"]
    assert usum["plus_minus"] == pytest.approx(abs(usum["value"] - usum["coarse_value"]))
    assert est["usum_text"].startswith(f"USUM = {res['usum_mm']:.4g} mm +- ")
    assert est["coarse_mesh"]["dofs"] < res["dofs"]
    # the tissue's stress peak sits at a sharp rim corner: a singularity, so no estimate is attached
    peak = est["at_forces"][-1]["regions.tissue.seqv_pa"]
    corners = res["geometry"]["corners_mm"]
    assert min(math.dist(peak["at_mm"], c) for c in corners) <= res["scene"]["output"]["rim_exclusion_mm"]
    assert peak["plus_minus"] is None and "singularity" in peak["note"]
    # the critical-distance average has a limit even there: it gets its +-
    average = est["at_forces"][-1]["regions.tissue.seqv_cd_pa"]
    assert average["plus_minus"] == pytest.approx(abs(average["value"] - average["coarse_value"]))
    assert average["plus_minus"] < 0.5 * average["value"]


@pytest.mark.long  # 15-25 s: benchmarks/long_tests.py runs it
def test_convergence_command_writes_the_ledger(tmp_path):
    """Three rim levels of a one-cone scene, each its own `suture-fem run` process."""
    from suture_fem.cli import main

    out = tmp_path / "ledger"
    args = ["convergence", "paper", *sets(FAST + ["geometry.cones=1"]), "--degrees", "1", "--refinements", "0,1,2",
            "--refine", "rim", "--out", str(out)]
    assert main(args) == 0
    ledger = json.loads((out / "ledger.json").read_text())
    assert [r["name"] for r in ledger["rungs"]] == ["p1_rim0", "p1_rim1", "p1_rim2"]
    for rung in ledger["rungs"]:
        assert rung["status"] == "converged" and rung["peak_memory_mb"] > 0 and rung["wall_time_s"] > 0
        assert (out / "rungs" / rung["name"] / "results.json").exists()
    dofs = [r["dofs"] for r in ledger["rungs"]]
    assert dofs == sorted(dofs) and len(set(dofs)) == 3
    per_q = ledger["analysis"]["1"]
    assert set(per_q) == {q.path for q in QUANTITIES}
    for path, p in per_q.items():
        est = p["estimates"]["P1"]
        if "_fillet" in path:  # the peak on a resolved fillet: absent with the default sharp rims
            assert est["refinements"] == [] and not est["values"], (path, est)
            continue
        assert est["refinements"] == [0, 1, 2] and len(est["values"]) == 3
        if est["verdict"] == "converging":
            assert math.isfinite(est["limit"]) and est["order"] > 0
    md = (out / "ledger.md").read_text()
    assert "| P1 rim2 |" in md and "USUM" in md
    assert (out / "ledger.png").stat().st_size > 10_000
    # a second call reuses every rung instead of solving again
    before = (out / "rungs" / "p1_rim0" / "results.json").stat().st_mtime_ns
    assert main(args) == 0
    assert (out / "rungs" / "p1_rim0" / "results.json").stat().st_mtime_ns == before


def test_convergence_rejects_a_bad_ladder_before_solving(tmp_path):
    from suture_fem.cli import main

    assert main(["convergence", "paper", "--degrees", "3", "--out", str(tmp_path)]) == 2
    assert main(["convergence", "paper", "--forces", "7", "--out", str(tmp_path)]) == 2
    assert not (tmp_path / "rungs").exists()


def test_singular_points_are_corners_junctions_and_where_interfaces_meet_the_end_faces():
    from suture_fem.geometry.section import Geometry
    from suture_fem.pipeline import load_scene
    from suture_fem.studies.convergence.singular import singular_points

    sharp = Geometry.from_section(load_scene("paper", ["geometry.cones=1"]).geometry)
    points = singular_points(sharp, 0.0)
    r_t, cone = sharp.r_thread, sharp.cones[0]
    assert set(map(tuple, sharp.corners)) <= set(points)
    assert (r_t, 0.0) in points and (r_t, sharp.length) in points  # the thread leaves the tissue's end faces
    assert (sharp.r_epidermis, sharp.length) in points  # the clamped outer surface meets a free end face
    assert (r_t, cone.apex_z) in points  # the apex cap meets the thread
    rounded = Geometry.from_section(load_scene("paper", ["geometry.cones=1", "geometry.cone_fillet_mm=0.05"]).geometry)
    kept = singular_points(rounded, 0.05)
    assert not any(abs(p[1] - cone.base_z) < 1e-9 for p in kept)  # the rounded base rim is not singular
    assert len(kept) == len(points) - 2
