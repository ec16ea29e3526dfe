"""The Newton solve's memo of its last iterate: recognised bit for bit, only inside a solve."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.solve.memo import IterateMemo


def _vec(values):
    vec = PETSc.Vec().createSeq(len(values), comm=PETSc.COMM_SELF)
    vec.setArray(np.asarray(values, dtype=float))
    return vec


def test_an_iterate_is_recognised_bit_for_bit_and_a_new_one_forgets_what_was_kept():
    memo = IterateMemo(MPI.COMM_SELF)
    x = _vec([1.0, 0.0, -2.5])
    with memo.open():
        assert not memo.at(x)
        memo.admissible, memo.potential = True, 3.0
        memo.keep_residual(_vec([0.5, 0.25, 0.0]))
        assert memo.at(_vec([1.0, 0.0, -2.5]))  # the same bits in another vector
        assert memo.admissible and memo.potential == 3.0 and memo.residual.tolist() == [0.5, 0.25, 0.0]
        assert not memo.at(_vec([1.0, -0.0, -2.5]))  # -0.0 == 0.0, but not the same bits
        assert memo.admissible is None and memo.potential is None and memo.residual is None
        assert not memo.at(_vec([1.0, 0.0, -2.5 + 1e-15]))


def test_nothing_is_kept_or_recognised_outside_a_solve():
    memo = IterateMemo(MPI.COMM_SELF)
    x = _vec([1.0, 2.0])
    assert not memo.at(x) and not memo.at(x)  # the load rate: one state under two loads, evaluated twice
    memo.keep_residual(_vec([1.0, 1.0]))
    assert memo.residual is None
    with memo.open():
        assert not memo.at(x) and memo.at(x)
        memo.potential = 1.0
    assert memo.potential is None and not memo.at(x)
