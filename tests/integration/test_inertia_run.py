"""The inertia correction in a run (``solver.inertia_correction``): it shifts the Jacobians with negative pivots
of the first steps and the answer is the same as without it.

One cone at P2 pulled to 1 N: its first step from rest inverts elements next to the cone's rims, where the
Jacobian has negative pivots (measured: 3 shifted Jacobians, 40 Newton iterations against 43 without).
"""

from __future__ import annotations

import pytest

from tests.conftest import run_inprocess

SCENE = ["geometry.cones=1", "mesh.degree=2", "mesh.refinement=0", "loading.force_n=1.0",
         "loading.report_forces_n=[0.5]", 'output.quantities=["usum"]']


@pytest.mark.long  # 12 s; benchmarks/long_tests.py
def test_the_shifted_jacobians_leave_the_answer_unchanged(tmp_path):
    on = run_inprocess("paper", SCENE, tmp_path / "on")
    off = run_inprocess("paper", SCENE + ["solver.inertia_correction=false"], tmp_path / "off")
    assert on["status"] == off["status"] == "converged"
    assert on["inertia_shifts"] > 0 and off["inertia_shifts"] == 0
    assert on["reaction_force_n"] == pytest.approx(-1.0, rel=1e-8)
    # both stop at an increment below 1e-7 of the state (the solver's stol), so the same equilibrium to about
    # that (measured: 7e-16 apart)
    for a, b in zip(on["at_forces"], off["at_forces"], strict=True):
        assert a["force_n"] == b["force_n"]
        assert a["usum_mm"] == pytest.approx(b["usum_mm"], rel=1e-7)
