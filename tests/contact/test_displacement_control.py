"""Displacement control (``loading.control = "displacement"``): the pulled end moved, the force its reaction.

Checked here: a ramp to the end displacement that a force-controlled ramp reached at 1 N takes 1 N there,
with the same lift (elastic and rigid suture); the outputs' force balance holds with the reaction as the
applied force; a sliding thread with no cone takes no force (the frictionless limit: under force control
the same scene stops with a diagnosis, no_axial_support); a step whose every start is outside the admissible
domain is cut before Newton (P2) and the run keeps its linear solver; scenes it cannot honour are refused in one
line.
"""

from __future__ import annotations

import pytest

from tests.conftest import FAST, cli, run_paper

SCENE = [*FAST, "geometry.cones=1", "output.quantities=[\"usum\",\"interface\"]"]
DISPLACEMENT = "loading.control=\"displacement\""


_run = run_paper


@pytest.mark.parametrize("suture", ["elastic", "rigid"])
def test_moving_the_end_where_a_force_took_it_takes_that_force(tmp_path_factory, suture):
    scene = [*SCENE, f"effects.suture=\"{suture}\""]
    force = _run(tmp_path_factory, f"force_{suture}", scene)
    end = force["thread_end_displacement_mm"]
    moved = _run(tmp_path_factory, f"moved_{suture}", [*scene, DISPLACEMENT, f"loading.displacement_mm={end!r}"])
    assert moved["control"] == "displacement" and "applied_force_n" not in moved
    rec = moved["at_forces"][-1]
    assert rec["force_n"] == pytest.approx(1.0, rel=1e-6)  # the reaction, reported as the state's force
    assert moved["thread_end_displacement_mm"] == pytest.approx(end, rel=1e-12)
    assert moved["usum_mm"] == pytest.approx(force["usum_mm"], rel=1e-6)
    assert rec["force_balance_rel"] < 1e-6
    assert sum(rec["load_share_n"].values()) == pytest.approx(rec["force_n"], rel=1e-6)
    curve = moved["force_displacement"]
    assert [p[1] for p in curve] == sorted(p[1] for p in curve) and curve[-1][0] == pytest.approx(rec["force_n"])


def test_a_sliding_thread_with_no_cone_takes_no_force_when_its_end_is_moved(tmp_path_factory):
    res = _run(tmp_path_factory, "slide0", [*SCENE, "geometry.cones=0", "effects.thread_interface=\"sliding\"",
                                            DISPLACEMENT, "loading.displacement_mm=1.0"])
    assert res["status"] == "converged"
    rec = res["at_forces"][-1]
    assert abs(rec["force_n"]) < 1e-9 and abs(rec["load_share_n"]["thread"]) < 1e-9
    assert res["thread_end_displacement_mm"] == pytest.approx(1.0, rel=1e-12)


def test_a_step_whose_every_start_is_inadmissible_is_cut_before_newton_and_keeps_the_linear_solver(tmp_path_factory):
    # P2, a frictionless thread: the end moved 0.8 mm in one step from rest inverts the suture's end element in every
    # start; Newton from there stepped 3.5e6 m, MUMPS failed and the run went on with superlu_dist (LU) for good
    res = _run(tmp_path_factory, "inadmissible_start",
               [*SCENE, "mesh.degree=2", "effects.thread_interface=\"frictionless\"", DISPLACEMENT,
                "loading.displacement_mm=0.8", "solver.initial_step=1", "solver.max_step=1"])
    assert res["status"] == "converged" and res["cutbacks"] == 1  # the first step cut, without a solve
    assert res["linear_solver"] == "mumps" and res["linear_solver_fallbacks"] == []
    assert res["thread_end_displacement_mm"] == pytest.approx(0.8, rel=1e-12)
    assert res["at_forces"][-1]["force_balance_rel"] < 1e-6


def test_displacement_control_with_inertia_is_refused_in_one_line():
    proc = cli(["show", "paper", "--set", DISPLACEMENT, "--set", "effects.inertia=true"])
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "loading.control" in lines[0] and "effects.inertia" in lines[0], proc.stderr
