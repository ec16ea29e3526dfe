"""`suture-fem holding`: the first failure bracketed on closed forms and on the tissue, bad strengths refused.

The thread's criterion is a closed form (its measure is the pull), so its bracket and band are exact;
the tissue's grows with its strength; 2 ranks give serial's answer; bad strengths stop in one line.
"""

from __future__ import annotations

import json

import pytest

from suture_fem import Scene
from suture_fem.studies.holding.curves import Sample, failure_force, first_failure
from suture_fem.studies.holding.study import holding
from tests.conftest import cli, sets

#: One cone, degree 1, coarsest mesh, first ramp to 1 N.
ONE_CONE = ["mesh.degree=1", "mesh.refinement=0", "loading.force_n=1.0", "geometry.cones=1"]
#: The tissue cases' bracket width and reports per ramp: one ramp to 1 N brackets the tear (0.125 N apart).
TOL, GRID = 0.15, 8
#: Tissue that never tears in these tests (1e4 MPa).
UNBREAKABLE = {f"strength.{layer}_pa": 1e10 for layer in ("hypodermis", "dermis", "epidermis")}


def _scene(values: dict | None = None) -> Scene:
    base = {k: json.loads(v) for k, v in (o.split("=") for o in ONE_CONE)}
    return Scene.builtin("paper").with_values({**base, **(values or {})})


def _samples(values: list[float]) -> list[Sample]:
    return [Sample(0.5 * (i + 1), {"hypodermis": v, "thread": 0.5 * (i + 1)},
                   {"hypodermis": [0.6, 3.0], "thread": None}) for i, v in enumerate(values)]


def test_crossing_is_interpolated_from_rest_and_the_first_part_wins():
    samples = _samples([10.0, 30.0, 70.0])
    c = failure_force(samples, "hypodermis", 20.0)
    assert (c.below_n, c.above_n, c.force_n) == (0.5, 1.0, pytest.approx(0.75))
    assert failure_force(samples, "hypodermis", 5.0).force_n == pytest.approx(0.25)  # from (0, 0)
    assert failure_force(samples, "hypodermis", 71.0) is None
    both = {"hypodermis": 20.0, "thread": 0.6}
    assert first_failure(samples, both).part == "thread" and first_failure(samples, both).force_n == pytest.approx(0.6)


def test_thread_break_is_bracketed_exactly_and_caps_the_holding_force(tmp_path):
    scene = _scene({**UNBREAKABLE, "strength.thread_break_n": 0.37})
    rec = holding(scene, None, tol_n=0.02, out=tmp_path, pictures=False, grid=GRID)
    lo, hi = rec["bracket_n"]
    assert rec["mode"] == "thread" and rec["layer"] is None and rec["cone"] is None
    assert lo < 0.37 <= hi and hi - lo <= 0.02
    assert rec["force_n"] == pytest.approx(0.37, rel=1e-12)  # the thread's measure is the pull itself
    assert rec["band_n"] == pytest.approx([0.37 * 0.83, 0.37 * 1.815], rel=1e-12)
    assert json.loads((tmp_path / "holding.json").read_text())["force_n"] == rec["force_n"]
    assert "thread breaks" in (tmp_path / "holding.md").read_text()


@pytest.fixture(scope="module")
def tissue(tmp_path_factory):
    """The fat tears first at the default strengths; then with the fat twice as strong."""
    weak = holding(_scene(), None, tol_n=TOL, out=tmp_path_factory.mktemp("weak"), pictures=False, grid=GRID)
    strong = holding(_scene({"strength.hypodermis_pa": 2 * 1.37e5}), None, tol_n=TOL, pictures=False, grid=GRID)
    return weak, strong


def test_tissue_tears_at_the_cone_where_its_measure_reaches_its_strength(tissue):
    weak, _ = tissue
    assert (weak["mode"], weak["layer"], weak["cone"]) == ("tear", "hypodermis", "cone_1")
    lo, hi = weak["bracket_n"]
    below = [s for s in weak["samples"] if s["force_n"] == lo]
    above = [s for s in weak["samples"] if s["force_n"] == hi]
    assert above[0]["hypodermis"] >= 1.37e5 and (lo == 0.0 or below[0]["hypodermis"] < 1.37e5)
    assert hi - lo <= TOL and lo <= weak["force_n"] <= hi
    assert weak["band_n"][0] < weak["force_n"] < weak["band_n"][1]
    assert weak["force_n"] < weak["strengths"]["value"]["thread"]


def test_holding_force_rises_with_the_strength(tissue):
    weak, strong = tissue
    assert strong["force_n"] > weak["force_n"] + 0.05
    assert strong["layer"] == "hypodermis"


def test_two_ranks_equal_serial(tissue, tmp_path):
    weak, _ = tissue
    proc = cli(["holding", "paper", *sets(ONE_CONE), "--tol", str(TOL), "--reports", str(GRID), "--no-pictures",
                "--out", str(tmp_path)], ranks=2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    rec = json.loads((tmp_path / "holding.json").read_text())
    assert (rec["mode"], rec["layer"], rec["cone"], rec["bracket_n"]) == (
        weak["mode"], weak["layer"], weak["cone"], weak["bracket_n"])
    assert rec["force_n"] == pytest.approx(weak["force_n"], rel=1e-6)
    assert rec["at_mm"] == pytest.approx(weak["at_mm"], abs=1e-9)


@pytest.mark.parametrize("args, says", [
    (["--set", "strength.dermis_pa=0"], "strength.dermis_pa = 0"),
    (["--set", "strength.hypodermis_pa=-5"], "strength.hypodermis_pa = -5"),
    (["--set", "strength.dermis_strain=0.01"], "strength.dermis_strain = 0.01"),
    (["--set", "strength.thread_break_band=[1.2, 2.0]"], "strength.thread_break_band"),
    (["--tol", "0"], "--tol"),
    (["--reports", "1"], "--reports"),
    (["--calibration", "no-such-file.json"], "--calibration"),
])
def test_bad_strengths_stop_in_one_line_before_meshing(args, says, tmp_path):
    proc = cli(["holding", "paper", *args, "--out", str(tmp_path / "out")])
    assert proc.returncode == 2, proc.stderr[-1000:]
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and says in lines[0], proc.stderr
    assert not (tmp_path / "out").exists()
