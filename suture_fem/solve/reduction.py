"""The reduction u = T x + g between the state's dofs and the unknowns x SNES solves for.

T injects the free dofs (:data:`~suture_fem.physics.constraints.FREE`) and, with a rigid suture, copies
the one rigid axial motion d onto every axial suture dof (RIGID); a fixed dof (FIXED) gets no column. A 3-D
sliding thread's track node (HOOP) has one column for its x-z plane: u_x = t_x s, u_z = t_z s, t the hoop
direction, so u . e_r = 0 there.
The residual and Jacobian SNES sees are T^T R(T x + g) and T^T A T (PETSc PtAP), so the Dirichlet
conditions and the rigid constraint need no special rows.

g is an optional affine offset: a vector of the state's layout that carries the values of the fixed
dofs and is zero on every other dof. A scene's Dirichlet conditions are all zero, so its solves have
no offset (u = T x exactly); the verification problems (:mod:`suture_fem.studies.verification`)
prescribe the exact solution on their boundary through g.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np
from petsc4py import PETSc

from suture_fem.physics.constraints import FREE, RIGID, Unknowns
from suture_fem.support import compat


class Discrete(Protocol):
    """What the Newton solver reads of a discrete problem.

    A scene's :class:`~suture_fem.physics.problem.Physics` is one; the verification problems are others.

    Attributes:
        W, state: the space of the unknown and the unknown Function.
        unknowns: which of the state's dofs are FREE, FIXED or RIGID.
        rigid_displacement: the Constant d of a rigid suture (None without one).
    """

    W: Any
    state: Any
    unknowns: Unknowns
    rigid_displacement: Any

    @property
    def comm(self) -> Any:
        """The communicator of the mesh."""

    def form(self, name: str) -> Any:
        """The compiled form ``residual`` or ``jacobian`` (the derivative of the residual)."""

    def sync(self) -> None:
        """Bring any view of the state (the displacement of a mixed state) up to date."""


class Reduction:
    """u = T x + g between the state's dofs and the unknowns SNES solves for (see the module docstring)."""

    def __init__(self, problem: Discrete, offset: Any = None):
        """Build T from ``problem.unknowns``; ``offset`` is g (a PETSc Vec of the state's layout) or None."""
        comm = problem.comm
        un = problem.unknowns
        W = problem.W
        bs = W.dofmap.index_map_bs
        im = W.dofmap.index_map
        kind = un.kind[: un.n_owned]
        free = np.flatnonzero(kind == FREE)
        rigid = np.flatnonzero(kind == RIGID)
        n_free = len(free)
        n_hoop = un.count_hoop()
        offset_col = comm.exscan(n_free + n_hoop) or 0
        n_free_global = comm.allreduce(n_free + n_hoop)
        holds_d = un.rigid and comm.rank == comm.size - 1
        self.d_owner = comm.size - 1 if un.rigid else None
        n_cols = n_free + n_hoop + (1 if holds_d else 0)
        self.n_global = n_free_global + (1 if un.rigid else 0)
        col = np.full(un.n_owned, -1, dtype=PETSc.IntType)
        col[free] = offset_col + np.arange(n_free)
        col[rigid] = n_free_global  # d is the last unknown
        value = np.ones(un.n_owned)
        if n_hoop:  # one column per hoop motion s: u_x = t_x s, u_z = t_z s
            owned = un.hoop[:, 0] < un.n_owned
            pairs, dirs = un.hoop[owned], un.hoop_dirs[owned]
            col[pairs] = (offset_col + n_free + np.arange(n_hoop))[:, None]
            value[pairs] = dirs
        has = col >= 0
        indptr = np.concatenate([[0], np.cumsum(has)]).astype(PETSc.IntType)
        self.T = PETSc.Mat().createAIJ(
            size=((un.n_owned, im.size_global * bs), (n_cols, self.n_global)),
            csr=(indptr, col[has], value[has]),
            comm=comm,
        )
        self.T.assemble()
        self.counts = self.T.createVecRight()
        ones = self.T.createVecLeft()
        ones.set(1.0)
        self.T.multTranspose(ones, self.counts)
        ones.destroy()
        # A hoop column's entries are a unit vector: T^T u is the hoop component itself. The column is owned here,
        # so its count is written in place (an assemble() is collective and some ranks hold no hoop column).
        self.counts.array[n_free : n_free + n_hoop] = 1.0
        self.problem = problem
        self.offset = offset

    def create_vector(self) -> Any:
        """A vector of the unknowns x."""
        return self.T.createVecRight()

    def restrict(self, u_vec: Any, x: Any) -> None:
        """X from a state u that satisfies the constraints (the mean over each column's dofs).

        The offset g is zero on every dof that has a column, so it drops out here.
        """
        self.T.multTranspose(u_vec, x)
        x.pointwiseDivide(x, self.counts)

    def expand(self, x: Any) -> None:
        """The state u = T x + g (ghosts updated, displacement view synced)."""
        u_vec = compat.function_vector(self.problem.state)
        self.T.mult(x, u_vec)
        if self.offset is not None:
            u_vec.axpy(1.0, self.offset)
        u_vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self.problem.sync()
        if self.d_owner is not None:  # the rigid suture's axial motion, for its boundary condition
            comm = self.problem.comm
            d = x.getArray(readonly=True)[-1] if comm.rank == self.d_owner else None
            self.problem.rigid_displacement.value = comm.bcast(d, root=self.d_owner)

    def destroy(self) -> None:
        """Free T and its column counts (not the offset, which belongs to the caller)."""
        self.T.destroy()
        self.counts.destroy()
