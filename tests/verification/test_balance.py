"""Balance of the production solve: reaction = applied force, external work = stored energy.

Both are identities of the discrete equations, whatever the mesh: at a converged state the sum of
the residual's axial entries is zero, so the reaction of the fixed outer surface is minus the applied
force to the Newton tolerance; and along a quasi-static hyperelastic load path dE/dF = F d(delta)/dF
with delta the 2 pi r-weighted mean axial displacement of the pulled face, so the stored strain
energy at the end equals the work int F d(delta). What the results carry is that work integrated by
the trapezoid rule over the converged load steps, whose error falls like the square of the load
step: the refinement that closes this gap is the load path's, not the mesh's. The test runs the
quick scene (one cone) with 10 and 20 equal steps and checks the second-order closing, and that the
Richardson limit of the two trapezoid sums (which removes the step^2 term) is closer to the stored
energy than the finer sum (what is left is the step^4 remainder).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import FAST, run_inprocess


def trapezoid_work_j(results: dict) -> float:
    fd = np.array(results["force_displacement"])
    return float(np.sum(0.5 * (fd[1:, 0] + fd[:-1, 0]) * np.diff(fd[:, 1]))) * 1e-3  # N * mm -> J


@pytest.fixture(scope="module")
def ramps(tmp_path_factory):
    out = {}
    for steps in (10, 20):
        step = 1.0 / steps
        sets = FAST + ["geometry.cones=1", "loading.report_forces_n=[]", f"solver.initial_step={step}",
                       f"solver.max_step={step}", "solver.grow=1.0"]
        out[steps] = run_inprocess("paper", sets, tmp_path_factory.mktemp(f"steps{steps}"))
    return out


def test_reaction_equals_applied_force(ramps):
    for res in ramps.values():
        rec = res["at_forces"][-1]
        bound = math.sqrt(res["dofs"]) * rec["free_residual_norm_n"] + 1e-14 * rec["force_n"]
        assert abs(rec["reaction_force_n"] + rec["force_n"]) <= bound


def test_external_work_equals_stored_energy_as_load_steps_shrink(ramps):
    coarse, fine = ramps[10], ramps[20]
    assert len(coarse["force_displacement"]) == 11 and len(fine["force_displacement"]) == 21
    energy = fine["strain_energy_j"]
    assert coarse["strain_energy_j"] == pytest.approx(energy, rel=1e-9)  # same end state
    w_coarse, w_fine = trapezoid_work_j(coarse), trapezoid_work_j(fine)
    gap_coarse, gap_fine = abs(w_coarse - energy) / energy, abs(w_fine - energy) / energy
    order = math.log2(gap_coarse / gap_fine)
    assert 1.5 <= order <= 2.5, f"gaps {gap_coarse:.3g} -> {gap_fine:.3g}: order {order:.2f}, trapezoid is 2"
    w_limit = w_fine + (w_fine - w_coarse) / 3.0
    assert abs(w_limit - energy) / energy < gap_fine, f"limit gap {abs(w_limit - energy) / energy:.3g}"
