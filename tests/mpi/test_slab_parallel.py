"""`mpirun -n 2 suture-fem run` on the coarse slab: the skin's outputs (dimple depth per cone, profile) as serial."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import run_paper
from tests.integration.test_slab_run import COARSE_SLAB
from tests.mpi.conftest import REL

pytestmark = [pytest.mark.mpi, pytest.mark.slow, pytest.mark.long]  # 43 s: benchmarks/long_tests.py

QUANTITIES = ("usum_mm", "skin_inward_mm", "skin_outward_mm", "reaction_force_n", "strain_energy_j")


def test_two_ranks_give_the_serial_skin(tmp_path_factory):
    serial = run_paper(tmp_path_factory, "slab_1", COARSE_SLAB, timeout=600)
    parallel = run_paper(tmp_path_factory, "slab_2", COARSE_SLAB, ranks=2, timeout=600)
    assert parallel["mpi_ranks"] == 2 and parallel["dofs"] == serial["dofs"]
    # the reported force is summed over the ranks' facets: equal to roundoff
    assert [r["force_n"] for r in parallel["at_forces"]] == pytest.approx([r["force_n"] for r in serial["at_forces"]],
                                                                          rel=REL)
    for a, b in zip(serial["at_forces"], parallel["at_forces"]):
        for q in QUANTITIES:
            assert b[q] == pytest.approx(a[q], rel=REL), (a["force_n"], q)
        assert b["dimple_depth_mm"] == pytest.approx(a["dimple_depth_mm"], rel=REL)
        for at_b, at_a in zip(b["dimple_depth_at_mm"], a["dimple_depth_at_mm"]):  # the same node (coordinates may be 0)
            np.testing.assert_allclose(at_b, at_a, rtol=REL, atol=1e-12)
        assert b["dimple_relief_mm"] == pytest.approx(a["dimple_relief_mm"], rel=REL, abs=1e-12)
        assert b["dimple_relief_at_y_mm"] == pytest.approx(a["dimple_relief_at_y_mm"], rel=REL)
        assert [y for y, _ in b["skin_profile_mm"]] == pytest.approx([y for y, _ in a["skin_profile_mm"]], rel=REL)
        assert [u for _, u in b["skin_profile_mm"]] == pytest.approx([u for _, u in a["skin_profile_mm"]], rel=REL)
