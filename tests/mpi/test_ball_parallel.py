"""The 3-D critical-distance ball on 2 ranks: tests/unit/test_ball_average.py's and test_ball_search.py's checks
hold on a partitioned mesh."""

from __future__ import annotations

import subprocess

import pytest

from tests.conftest import PYTHON, ROOT, mpi_env, mpirun

pytestmark = [pytest.mark.mpi]


def test_ball_averages_on_two_ranks():
    """Each rank runs the unit tests on its part of the box: the collective averages and searches pass the same
    assertions (the search's largest averages and their centres)."""
    cmd = [*mpirun(2), PYTHON, "-P", "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/unit/test_ball_average.py",
           "tests/unit/test_ball_search.py"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(), cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    assert proc.stdout.count("7 passed") == 2  # both ranks ran all seven
