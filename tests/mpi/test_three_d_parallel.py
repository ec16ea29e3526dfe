"""`mpirun -n 2 suture-fem run` on the coarse 3-D cylinder: the same numbers as the serial run."""

from __future__ import annotations

import json

import pytest

from tests.conftest import cli, sets
from tests.integration.test_three_d_run import COARSE_3D
from tests.mpi.conftest import REL

pytestmark = [pytest.mark.mpi, pytest.mark.slow]

QUANTITIES = ("usum_mm", "seqv_pa", "eptoeqv", "thread_end_displacement_mm", "reaction_force_n", "strain_energy_j")


def _run(tmp_path_factory, ranks: int) -> dict:
    out = tmp_path_factory.mktemp(f"three_d_{ranks}")
    proc = cli(["run", "paper", *sets(COARSE_3D), "--no-pictures", "--out", str(out)], ranks=ranks, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return json.loads((out / "results.json").read_text())


def test_two_ranks_equal_serial_in_3d(tmp_path_factory):
    serial, parallel = _run(tmp_path_factory, 1), _run(tmp_path_factory, 2)
    assert parallel["mpi_ranks"] == 2 and parallel["dofs"] == serial["dofs"]
    assert [r["force_n"] for r in parallel["at_forces"]] == [r["force_n"] for r in serial["at_forces"]]
    for a, b in zip(serial["at_forces"], parallel["at_forces"]):
        for q in QUANTITIES:
            assert b[q] == pytest.approx(a[q], rel=REL), (a["force_n"], q)
        for region in ("hypodermis", "dermis", "epidermis", "suture"):
            assert b["regions"][region]["usum_mm"] == pytest.approx(a["regions"][region]["usum_mm"], rel=REL)
