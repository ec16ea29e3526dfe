"""`suture-fem reproduce` on a coarse mesh: the paper's trends, the comparison table, the pictures.

One in-process run of the whole command (degree 1, coarsest mesh, the solver's default steps), shared
by the tests of this module; the calibration search is tested on synthetic USUM curves (no solve).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from suture_fem.studies import reproduce as rp

COARSE = ["mesh.degree=1", "mesh.refinement=0", "solver.initial_step=0.1", "solver.max_step=0.25"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from suture_fem.cli import main

    out = tmp_path_factory.mktemp("reproduce")
    args = ["reproduce", "--out", str(out)]
    for o in COARSE:
        args += ["--set", o]
    assert main(args) == 0
    cmp = json.loads((out / "comparison.json").read_text())
    results = {n: json.loads((out / f"cones_{n}" / "results.json").read_text()) for n in rp.CONES}
    return out, cmp, results


def at(results: dict, force: float) -> dict:
    return next(r for r in results["at_forces"] if abs(r["force_n"] - force) <= 1e-9 * force)


def test_every_cone_count_reaches_4n_with_reports_at_1_to_4n(run):
    _, cmp, results = run
    assert cmp["stopped"] == {}
    for n, res in results.items():
        assert res["status"] == "converged"
        assert res["scene"]["geometry"]["cones"] == n
        assert [r["force_n"] for r in res["at_forces"]] == pytest.approx(list(rp.FORCES_N))


def test_usum_falls_with_cone_count(run):
    _, _, results = run
    usum = [at(results[n], 1.0)["usum_mm"] for n in rp.CONES]
    assert all(b < a for a, b in zip(usum, usum[1:])), usum


def test_usum_grows_less_than_linearly_with_force(run):
    """The tissue stiffens (Yeoh C20 > 0): USUM rises with F, but USUM / F falls, for every cone count."""
    _, _, results = run
    for n, res in results.items():
        usum = np.array([at(res, f)["usum_mm"] for f in rp.FORCES_N])
        assert np.all(np.diff(usum) > 0), (n, usum)
        assert np.all(np.diff(usum / np.array(rp.FORCES_N)) < 0), (n, usum)


@pytest.mark.parametrize("measure", ["seqv_pa", "seqv_outside_rim_pa", "eptoeqv", "eptoeqv_outside_rim"])
def test_tissue_stress_and_strain_fall_with_cone_count(run, measure):
    """Table 2's trend (2, 3, 4 cones at 1 N), for the peak and for the converging measure outside the rims:
    more cones share the same force, so each cone loads the tissue less."""
    _, _, results = run
    values = [at(results[n], 1.0)["regions"]["tissue"][measure] for n in (2, 3, 4)]
    assert all(b < a for a, b in zip(values, values[1:])), values


def test_comparison_lists_every_paper_value_once_with_its_role(run):
    _, cmp, _ = run
    rows = cmp["rows"]
    keys = [(r["source"], r["cones"], r["force_n"], r["quantity"]) for r in rows]
    assert len(keys) == len(set(keys)) == len(rp.PAPER) == 12 + 6 + 3  # Table 1, Table 2, section 2.2
    roles = {k: r["role"] for k, r in zip(keys, rows)}
    typo = ("Table 1", 4, 1.0, "seqv_pa")
    target = ("Table 1", 4, 1.0, "usum_mm")
    assert roles[typo] == "not used: typo"
    assert roles[target] in ("calibrated", "calibration target (not reached)")
    assert {v for k, v in roles.items() if k not in (typo, target)} == {"predicted"}
    typo_row = rows[keys.index(typo)]
    assert typo_row["paper"] == pytest.approx(23549e3) and typo_row["note"]
    assert typo_row["rel_error"] is None and typo_row["rel_error_outside_rims"] is None
    # the same case, correctly printed, is compared: Table 2, 4 cones, 235490 Pa
    assert rows[keys.index(("Table 2", 4, 1.0, "seqv_pa"))]["rel_error"] is not None


def test_comparison_values_are_ours_and_errors_are_relative(run):
    """USUM is the model maximum; SEQV and EPTOEQV the tissue maxima (the overall SEQV maximum is the
    thread's axial stress, which the paper does not report)."""
    _, cmp, results = run
    for r in cmp["rows"]:
        rec = at(results[r["cones"]], r["force_n"])
        expected = rec["usum_mm"] if r["quantity"] == "usum_mm" else rec["regions"]["tissue"][r["quantity"]]
        assert r["ours"] == expected
        if r["quantity"] == "seqv_pa":
            assert r["ours"] < rec["seqv_pa"] and rec["seqv_pa_region"] == "suture"
            assert r["ours_outside_rims"] == rec["regions"]["tissue"]["seqv_outside_rim_pa"]
        if r["rel_error"] is not None:
            assert r["rel_error"] == pytest.approx((r["ours"] - r["paper"]) / r["paper"], rel=1e-12)
    predicted = [r for r in cmp["rows"] if r["role"] == "predicted"]
    worst = max(predicted, key=lambda r: abs(r["rel_error"]))
    assert cmp["largest_prediction_error"] == worst
    # USUM relative to the calibration case: ours / ours(4 cones, 1 N) against paper / 4.0 mm
    ref = at(results[4], 1.0)["usum_mm"]
    shape = cmp["usum_relative_to_target"]
    assert len(shape) == sum(r["quantity"] == "usum_mm" for r in cmp["rows"])
    for r in shape:
        assert r["ours"] == pytest.approx(at(results[r["cones"]], r["force_n"])["usum_mm"] / ref, rel=1e-12)


def test_trend_flags_agree_with_the_values(run):
    _, cmp, _ = run
    for t in cmp["trends"]:
        v = t["ours"]
        if t["trend"].startswith("USUM grows less"):
            per_n = [u / f for u, f in zip(v, rp.FORCES_N)]
            expected = all(b > a for a, b in zip(v, v[1:])) and all(b < a for a, b in zip(per_n, per_n[1:]))
        elif "falls" in t["trend"]:
            expected = all(b < a for a, b in zip(v, v[1:]))
        else:
            expected = all(b > a for a, b in zip(v, v[1:]))
        assert t["holds"] is expected, t["trend"]


def test_markdown_table_has_every_row_and_flags_the_typo(run):
    out, cmp, _ = run
    md = (out / "comparison.md").read_text()
    values = md[md.index("## Values"):md.index("USUM relative to the 4-cone")]
    table = [line for line in values.splitlines() if line.startswith("| Table") or line.startswith("| Section")]
    assert len(table) == len(cmp["rows"])
    assert all(line.count("|") == 11 for line in table)
    assert "| 23549 kPa |" in md and "not used: typo" in md
    assert "Wall time of the whole command" in md


def test_fields_match_the_reported_usum_and_pictures_are_drawn(run):
    from matplotlib import image

    from suture_fem import plots

    out, cmp, results = run
    for n, f in ((1, 1.0), (4, 4.0)):
        grid = plots.load_grid(out / "fields" / f"cones{n}_{f:g}N.vtu")
        # degree 1: the grid's points are the displacement nodes, so its maximum is USUM exactly
        assert float(grid.point_data["usum_mm"].max()) == pytest.approx(at(results[n], f)["usum_mm"], rel=1e-12)
        full = plots.full_section(grid, deformed=False)
        assert full.bounds[2] == pytest.approx(-full.bounds[3])  # mirrored r -> -r
    names = {"fig2_usum_4_cones.png", "fig3_usum_1_n.png", "fig4_force_displacement.png", "trends_vs_cones.png",
             "trends_vs_force.png"}
    assert set(cmp["figures"]) == names
    for name in names:
        img = image.imread(out / name)
        colours = np.unique((img[..., :3] * 255).astype(np.uint8).reshape(-1, 3), axis=0)
        assert img.shape[0] > 300 and img.shape[1] > 600 and len(colours) > 20, name


def test_nice_levels_have_a_round_step_and_cover_the_range():
    from suture_fem.plots import nice_levels

    for hi in (0.37, 4.66, 7.31, 12.0):
        levels = nice_levels(0.0, hi)
        step = levels[1] - levels[0]
        mantissa = step / 10 ** np.floor(np.log10(step))
        assert min(abs(mantissa - m) for m in (1, 2, 2.5, 5)) < 1e-9
        assert levels[0] == 0.0 and levels[-1] >= hi and levels[-2] < hi
        assert np.allclose(np.diff(levels), step)


def base_scene():
    """The typed scene the calibration records the mesh of (the synthetic curves solve nothing)."""
    from suture_fem.pipeline import load_scene

    return load_scene(rp.SCENE)


def test_calibration_search_finds_a_bracketed_target():
    slope = 0.05  # mm of USUM per mm of the dimension, falling
    calls = []

    def usum_of(v):
        calls.append(v)
        return 4.0 + slope * (12.0 - v) + 1e-3 * (12.0 - v) ** 2  # target reached at v = 12 mm

    cal = rp.calibrate(base_scene(), None, usum_of=usum_of)
    assert cal["status"] == "calibrated"
    assert abs(cal["usum_mm"] - 4.0) <= 2e-3 * 4.0
    # near v = 12 the curve's slope is -slope, so the dimension is within the USUM tolerance / slope
    assert cal["value_mm"] == pytest.approx(12.0, abs=2e-3 * 4.0 / slope * 1.5)
    assert len(calls) == len(cal["evaluations"]) <= 12
    assert calls[:2] == [rp.CALIBRATED.lo, rp.CALIBRATED.hi]


def test_calibration_search_reports_an_unreachable_target_and_moves_nothing():
    cal = rp.calibrate(base_scene(), None, usum_of=lambda v: 2.7 - 0.01 * v)
    assert cal["status"] == "unreachable"
    assert len(cal["evaluations"]) == 2
    assert cal["value_mm"] == rp.CALIBRATED.lo and cal["usum_mm"] == pytest.approx(2.7 - 0.01 * rp.CALIBRATED.lo)
    assert cal["rel_error"] == pytest.approx((cal["usum_mm"] - 4.0) / 4.0)


GRID_SCRIPT = """
import json, sys
import numpy as np
from mpi4py import MPI
from suture_fem import plots
from suture_fem.geometry import mesh as meshmod
from suture_fem.physics.problem import build_physics
from suture_fem.pipeline import load_scene

comm = MPI.COMM_WORLD
scene = load_scene("paper", sys.argv[1:])
physics = build_physics(meshmod.create_mesh(comm, scene.geometry, scene.mesh), scene)
physics.u.interpolate(lambda x: np.stack([2.0 * x[0] + x[1], 3.0 * x[1]]))  # linear: exact at the nodes
grid = plots.field_grid(physics)
n_cells = comm.allreduce(physics.mesh.topology.index_map(2).size_local)
if comm.rank == 0:
    z, r = grid.points[:, 0], grid.points[:, 1]  # mm
    u = grid.point_data["u_mm"]  # (u_z, u_r, 0)
    err = max(np.abs(u[:, 1] - (2.0 * r + z)).max(), np.abs(u[:, 0] - 3.0 * z).max())
    print(json.dumps({"points": grid.n_points, "cells": grid.n_cells,
                      "global_nodes": physics.V.dofmap.index_map.size_global, "global_cells": n_cells,
                      "max_error_mm": float(err), "max_u_mm": float(np.abs(u).max())}))
else:
    assert grid is None
"""


@pytest.mark.mpi
def test_field_grid_gathers_one_point_per_node_under_mpi(tmp_path):
    """On two ranks, nodes shared by both become one point (no seam in the pictures), every cell comes
    once, and each point carries its own node's displacement (a linear field, exact at the nodes)."""
    import subprocess
    import sys

    from tests.conftest import ROOT, mpi_env, mpirun

    script = tmp_path / "grid.py"
    script.write_text(GRID_SCRIPT)
    proc = subprocess.run(mpirun(2) + [sys.executable, str(script), "mesh.degree=1", "geometry.cones=1"],
                          capture_output=True, text=True, env=mpi_env(), cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["points"] == out["global_nodes"]
    assert out["cells"] == out["global_cells"]
    assert out["max_error_mm"] <= 1e-12 * out["max_u_mm"]
