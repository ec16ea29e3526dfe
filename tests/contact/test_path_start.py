"""The force ramp's path-following start (``loading.start_force_n``, solve/start.py).

Checked here: on a scene with one equilibrium per force (tied cones) a ramp that starts by moving the end
until it takes 0.3 N, then goes on under force control, reports the force ramp's state at 1 N (the same
USUM to the balance's tolerance), and results.json says where it switched; a start under displacement
control, or at a force not below every report, is refused in one line before any meshing.
"""

from __future__ import annotations

import pytest

from tests.conftest import FAST, cli, run_paper

SCENE = [*FAST, "geometry.cones=1", "output.quantities=[\"usum\"]"]
START = "loading.start_force_n=0.3"


def test_a_started_ramp_reports_the_force_ramps_state(tmp_path_factory):
    plain = run_paper(tmp_path_factory, "plain", SCENE)
    started = run_paper(tmp_path_factory, "started", [*SCENE, START, "loading.displacement_mm=4"])
    assert started["status"] == "converged" and "start" not in plain
    start = started["start"]
    assert start["control"] == "displacement" and start["force_n"] >= 0.3 and start["end_displacement_mm"] > 0
    assert start["newton_iterations"] > 0 and start["switch_iterations"] >= 0
    assert [r["force_n"] for r in started["at_forces"]] == [r["force_n"] for r in plain["at_forces"]]
    assert started["usum_mm"] == pytest.approx(plain["usum_mm"], rel=1e-6)
    assert started["at_forces"][-1]["force_balance_rel"] < 1e-6


@pytest.mark.parametrize("keys", [[START, "loading.control=\"displacement\""],
                                  [START, "loading.report_forces_n=[0.2]"]])
def test_a_start_it_cannot_honour_is_refused_in_one_line(keys):
    proc = cli(["show", "paper", *[a for k in keys for a in ("--set", k)]])
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "loading.start_force_n" in lines[0], proc.stderr
