"""What a Newton solve evaluated at its last iterate: the domain guard's verdict, the potential, the residual.

Inside one Newton solve (:meth:`~suture_fem.solve.newton.NewtonSolver.solve`, its SNES solves and their
continuation with the residual tests only) nothing but the iterate x changes: the loads, the material
constants and what the contact and friction terms hold between solves are fixed. The guard's verdict,
the potential and the residual at an iterate are then functions of x alone, and PETSc asks for some of
them twice:

* the backtracking line search (``bt``, with the energy as objective) starts by evaluating the
  potential at the current iterate: the trial state the previous line search accepted, whose potential
  it had just computed;
* after a line search, SNES asks for the residual at the accepted trial state, whose guard verdict the
  potential's evaluation had just made;
* a solve continued with the residual tests only starts with the residual its predecessor ended on.

:class:`IterateMemo` keeps each of them for the last iterate evaluated, recognised bit for bit, so each
is computed once: the same numbers, hence the same iterates and answers. Outside a solve
(:meth:`IterateMemo.open`) nothing is kept or recognised: the load rate evaluates the residual at one
state under two loads. Hand-written: PETSc 3.18's SNES has no option to reuse an objective value.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from mpi4py import MPI


class IterateMemo:
    """The guard's verdict (with its violation), the potential and the reduced residual at one iterate.

    Attributes:
        admissible: the guard's verdict there (None: not evaluated); violation: the guard's last violation.
        potential: the potential there (None: not evaluated).
        residual: a copy of the reduced residual's local array there (None: not evaluated, or outside).
    """

    def __init__(self, comm: Any):
        """An empty memo on ``comm`` (recognising an iterate is collective)."""
        self.comm = comm
        self._open = False
        self._key: np.ndarray | None = None
        self.admissible: bool | None = None
        self.violation: Any = None
        self.potential: float | None = None
        self.residual: np.ndarray | None = None

    @contextmanager
    def open(self) -> Iterator[None]:
        """Keep and recognise iterates inside this block only (one Newton solve); forget them when it ends."""
        self.forget()
        self._open = True
        try:
            yield
        finally:
            self._open = False
            self.forget()

    def at(self, x: Any) -> bool:
        """Whether x (a PETSc Vec) is, bit for bit, the iterate kept (collective); if not, keep x instead.

        Always False outside :meth:`open` (and nothing is kept then).
        """
        if not self._open:
            return False
        local = x.getArray(readonly=True)
        same = self._key is not None and self._key.shape == local.shape and bool(
            np.array_equal(self._key.view(np.int64), local.view(np.int64)))  # bits: -0.0 is not 0.0 here
        if self.comm.size > 1:
            same = bool(self.comm.allreduce(same, op=MPI.LAND))
        if not same:
            self.forget()
            self._key = local.copy()
        return same

    def keep_residual(self, b: Any) -> None:
        """Keep the residual just computed at the kept iterate (inside :meth:`open`)."""
        if self._open and self._key is not None:
            self.residual = b.getArray(readonly=True).copy()

    def forget(self) -> None:
        """Nothing kept: the next iterate is evaluated afresh."""
        self._key = None
        self.admissible, self.violation, self.potential, self.residual = None, None, None, None
