"""The reduction T on 2 ranks when only one rank owns a hoop column (a 3-D sliding thread's track node).

Which rank owns the track's nodes depends on the partition, which changes from run to run. A first version
finished the hoop columns' counts with a collective call on the ranks that own some: where the other rank owned
none, the run hung (1 run in 6 of the coarse 3-D sliding thread on 2 ranks). Here the last rank owns the only
hoop column, every time.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import ROOT, mpi_env, mpirun

pytestmark = pytest.mark.mpi

SCRIPT = """
import numpy as np
import dolfinx
from mpi4py import MPI
from types import SimpleNamespace
from suture_fem.physics.constraints import FREE, Unknowns
from suture_fem.solve.reduction import Reduction
from suture_fem.support import compat

comm = MPI.COMM_WORLD
mesh = dolfinx.mesh.create_unit_square(comm, 4, 4)
W = compat.vector_space(mesh, 1)
im, bs = W.dofmap.index_map, W.dofmap.index_map_bs
un = Unknowns(np.full((im.size_local + im.num_ghosts) * bs, FREE, np.int8), im.size_local * bs, False)
mine = comm.rank == comm.size - 1 and im.size_local > 0
un.hold_to_hoop(np.array([[0, 1]] if mine else np.zeros((0, 2), int)), np.array([[0.6, 0.8]] if mine else
                np.zeros((0, 2))))
problem = SimpleNamespace(comm=comm, unknowns=un, W=W, state=dolfinx.fem.Function(W), sync=lambda: None)
red = Reduction(problem)
x = red.create_vector()
lo, hi = x.getOwnershipRange()
x.array[:] = 1.0 + np.arange(lo, hi)
red.expand(x)
u = compat.function_vector(problem.state).array
y = red.create_vector()
red.restrict(compat.function_vector(problem.state), y)
n_cols = comm.allreduce(hi - lo)
hoop = comm.allreduce(un.count_hoop())
ok = comm.allreduce(float(np.max(np.abs(y.array - x.array), initial=0.0)), op=MPI.MAX) < 1e-14
if mine:
    s = x.array[-1]
    ok = ok and np.allclose(u[:2], [0.6 * s, 0.8 * s])
ok = comm.allreduce(int(not ok)) == 0
free = comm.allreduce(int(np.sum(un.kind[: un.n_owned] == FREE)))
if comm.rank == 0:
    print("columns", n_cols, "hoop", hoop, "free", free)
    print("round trip", "ok" if ok else "FAILED")
"""


def test_a_hoop_column_on_one_rank_alone(tmp_path):
    """Built on both ranks; x -> u = T x -> T^T u / counts gives x back; the hoop node moves along (0.6, 0.8)."""
    script = tmp_path / "reduction.py"
    script.write_text(SCRIPT)
    proc = subprocess.run(
        [*mpirun(2), sys.executable, "-P", str(script)],
        capture_output=True,
        text=True,
        env=mpi_env(),
        cwd=ROOT,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.split("\n")
    counts = lines[0].split()
    assert counts[0] == "columns" and counts[3] == "1"  # one hoop column in all
    assert int(counts[1]) == int(counts[5]) + 1  # the free dofs minus the hoop pair's two, plus one column
    assert lines[1] == "round trip ok"
