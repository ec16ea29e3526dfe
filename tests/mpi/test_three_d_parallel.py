"""`mpirun -n 2 suture-fem run` on the coarse 3-D cylinder: the same numbers as the serial run, the
critical-distance ball's largest averages and their centres included."""

from __future__ import annotations

import pytest

from tests.conftest import run_paper
from tests.integration.test_three_d_run import COARSE_3D_CD
from tests.mpi.conftest import REL

pytestmark = [pytest.mark.mpi, pytest.mark.slow]

QUANTITIES = ("usum_mm", "seqv_pa", "eptoeqv", "thread_end_displacement_mm", "reaction_force_n", "strain_energy_j",
              "seqv_cd_pa", "eptoeqv_cd", "seqv_cd_cone_pa", "eptoeqv_cd_cone")


def _run(tmp_path_factory, ranks: int) -> dict:
    return run_paper(tmp_path_factory, f"three_d_{ranks}", COARSE_3D_CD, ranks=ranks, timeout=600)


def test_two_ranks_equal_serial_in_3d(tmp_path_factory):
    serial, parallel = _run(tmp_path_factory, 1), _run(tmp_path_factory, 2)
    assert parallel["mpi_ranks"] == 2 and parallel["dofs"] == serial["dofs"]
    assert [r["force_n"] for r in parallel["at_forces"]] == [r["force_n"] for r in serial["at_forces"]]
    for a, b in zip(serial["at_forces"], parallel["at_forces"]):
        for q in QUANTITIES:
            assert b[q] == pytest.approx(a[q], rel=REL), (a["force_n"], q)
        for q in QUANTITIES[-4:]:  # the ball's centre: grids fixed in space, candidates gathered over the ranks
            assert b[q + "_at_mm"] == pytest.approx(a[q + "_at_mm"], abs=1e-9), (a["force_n"], q)
        for region in ("hypodermis", "dermis", "epidermis", "suture"):
            assert b["regions"][region]["usum_mm"] == pytest.approx(a["regions"][region]["usum_mm"], rel=REL)
