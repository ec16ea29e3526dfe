"""The sparsity of the terms assembled by hand (a Coulomb thread's friction, the cones' contact).

Their entries couple nodes that share no cell, so the Jacobian's pattern, preallocated by dolfinx for
the forms, has no room for them. :func:`widen` makes that room once, exactly: the union of the form's
pattern (read back from the assembled matrix) and the new entries, preallocated in one go
(``MatXAIJSetPreallocationCSR``). Inserting the new entries one by one instead makes PETSc reallocate
the whole matrix at every row that overflows (and, before the form's first assembly, at every row of
the form too: 18,000 reallocations, 4 s, on the paper scene with four cones).

:class:`ConeLayout` holds the cones' entries as compressed rows laid out once, so that each Jacobian
adds them with one ``MatSetValues`` per row from C (``setValuesIJV``) instead of a Python loop over pairs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from petsc4py import PETSc


def open_pattern(A: Any) -> None:
    """Let hand-assembled terms add entries to A: new nonzeros, and rows owned by another rank."""
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_LOCATION_ERR, False)
    A.setOption(PETSc.Mat.Option.NO_OFF_PROC_ENTRIES, False)


def widen(A: Any, rows: np.ndarray, cols: np.ndarray) -> None:
    """Make room in A for the entries (rows[i], cols[i]) (global indices, rows of any rank; collective).

    A should hold its forms' pattern (assembled once): what it holds is kept (as zeros), the rest of its
    preallocation is not. Its values are zero afterwards.
    """
    comm = A.getComm().tompi4py()
    rows, cols = np.asarray(rows, dtype=np.int64).ravel(), np.asarray(cols, dtype=np.int64).ravel()
    if comm.size > 1:  # entries in rows another rank owns go to it
        rows, cols = np.concatenate(comm.allgather(rows)), np.concatenate(comm.allgather(cols))
    start, end = A.getOwnershipRange()
    mine = (rows >= start) & (rows < end)
    if not A.assembled:
        A.assemble()
    indptr, indices, _ = A.getValuesCSR()
    n_cols = int(A.getSize()[1])
    held = np.repeat(np.arange(end - start, dtype=np.int64), np.diff(indptr))
    keys = np.unique(np.concatenate([held * n_cols + indices, (rows[mine] - start) * n_cols + cols[mine]]))
    local_rows, new_cols = np.divmod(keys, n_cols)
    pointer = np.searchsorted(local_rows, np.arange(end - start + 1))
    A.setPreallocationCSR((pointer.astype(PETSc.IntType), new_cols.astype(PETSc.IntType)))
    open_pattern(A)


class ConeLayout:
    """The cones' Hessian entries as compressed rows (global dofs), laid out once (:class:`ConeContact`'s).

    For each cone with pairs k (dofs a_k = (u_r, u_z); 3-D (u_x, u_y, u_z)) and interface axial dofs b (n_b of them,
    alpha = 1 / n_b; the axial component is the second in both):
    K_aa = H_k, K_ab = K_ba^T = -H_k[:, z] alpha, K_bb = sum_k H_k[z, z] alpha^2 (every b, b').
    """

    def __init__(self, dofs: np.ndarray, cone: np.ndarray, cone_dofs: list[np.ndarray]):
        """``dofs``: (pairs, dim) global dofs; ``cone``: each pair's cone; ``cone_dofs``: per cone, its axial dofs."""
        self.dofs, self.cone, self.cone_dofs = dofs, cone, cone_dofs
        self.parts = []  # per cone: (its pairs, its axial dofs)
        rowmap, lengths, cols = [], [], []
        d = dofs.shape[1]
        for c, b in enumerate(cone_dofs):
            sel = np.flatnonzero(cone == c)
            b = np.asarray(b, dtype=np.int64)
            if not len(sel):
                continue
            self.parts.append((sel, b))
            a = dofs[sel].astype(np.int64)  # (P, d)
            rowmap.append(a.ravel())  # a pair's rows: its own d dofs, then every b
            lengths.append(np.full(a.size, d + len(b)))
            cols.append(np.concatenate([np.repeat(a, d, axis=0), np.tile(b, (a.size, 1))], axis=1).ravel())
            if len(b):  # each b's row: every pair's dofs, then every b
                rowmap.append(b)
                lengths.append(np.full(len(b), a.size + len(b)))
                cols.append(np.tile(np.concatenate([a.ravel(), b]), len(b)))
        self.rowmap = np.concatenate(rowmap or [np.zeros(0, np.int64)]).astype(PETSc.IntType)
        self.indptr = np.concatenate([[0], np.cumsum(np.concatenate(lengths or [np.zeros(0, np.int64)]))])
        self.indptr = self.indptr.astype(PETSc.IntType)
        self.cols = np.concatenate(cols or [np.zeros(0, np.int64)]).astype(PETSc.IntType)

    def values(self, hess: np.ndarray) -> np.ndarray:
        """The entries, in the layout's order, of every pair's Hessian ``hess`` ((pairs, d, d))."""
        out = []
        for sel, b in self.parts:
            H = hess[sel]
            alpha = 1.0 / max(len(b), 1)
            couple = -H[:, :, 1] * alpha  # (P, d): K_ab's row of each pair's dof
            out.append(np.concatenate([H, np.repeat(couple[:, :, None], len(b), axis=2)], axis=2).ravel())
            if len(b):
                row = np.concatenate([couple.ravel(), np.full(len(b), float(np.sum(H[:, 1, 1])) * alpha * alpha)])
                out.append(np.tile(row, len(b)))
        return np.concatenate(out or [np.zeros(0)])

    def add_gradient(self, b: Any, nodal: np.ndarray, axial: np.ndarray) -> None:
        """Add a gradient to b (not assembled here): each pair's ``nodal`` values ((pairs, dim)) at its dofs.

        Each cone's axial dofs get -alpha x the sum of its pairs' ``axial`` components (the place moves by -t_c e_z).
        """
        rows, values = [self.dofs.ravel()], [nodal.ravel()]
        for c, dofs in enumerate(self.cone_dofs):
            if len(dofs):
                rows.append(dofs)
                values.append(np.full(len(dofs), -float(np.sum(axial[self.cone == c])) / len(dofs)))
        b.setValues(np.concatenate(rows).astype(PETSc.IntType), np.concatenate(values),
                    addv=PETSc.InsertMode.ADD_VALUES)

    def add(self, A: Any, hess: np.ndarray) -> None:
        """Add the entries of ``hess`` to A (not assembled here)."""
        A.setValuesIJV(self.indptr, self.cols, self.values(hess), addv=PETSc.InsertMode.ADD_VALUES,
                       rowmap=self.rowmap)

    def entries(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) of every entry, for :func:`widen`."""
        return np.repeat(self.rowmap, np.diff(self.indptr)), self.cols
