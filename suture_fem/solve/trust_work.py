"""A trust-region solve's vectors and shifted matrices, linear solve and step test (:mod:`suture_fem.solve.trust`)."""

from __future__ import annotations

from typing import Any

from petsc4py import PETSc

#: A step is kept when the energy falls by at least this fraction of the model's prediction.
RHO_KEEP = 1e-4


class Work:
    """The vectors and the shifted matrix of one trust-region solve."""

    def __init__(self, x: Any):
        self.trial, self.p, self.p0, self.Ap = (x.duplicate() for _ in range(4))
        self.M: Any = None
        self.diag: Any = None
        self.scale: Any = None
        self.lam0 = self.lam = 0.0
        self.carry = 0.0  # the radius at the last step above the energy's rounding
        self.joins, self.theta = 0, 0.0  # the last step's joined solves and its negative curvature (0: none)
        self.base = 0.0  # the last step's |p| before its completion along z
        self.norm0 = 0.0
        self.pressing = 0.0  # the open pairs' model energy at the step (J)
        self.F: Any = None  # the full Jacobian with joined pairs, its reduction K (made by ptap), their residuals b, g
        self.K: Any = None
        self.b: Any = None
        self.g = x.duplicate()

    def joined(self, newton: Any) -> None:
        """F = the iterate's full Jacobian, b = 0: ready for the joined pairs' terms."""
        if self.F is None:
            self.F = newton.A_full.duplicate(copy=True)
            self.b = newton.b_full.duplicate()
        else:
            newton.A_full.copy(self.F, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self.b.set(0.0)

    def matrix(self, A: Any) -> None:
        """M = A's copy (to be shifted), its diagonal and |diag A|."""
        if self.M is None:
            self.M = A.duplicate(copy=True)
        else:
            A.copy(self.M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        for v in (self.diag, self.scale):
            if v is not None:
                v.destroy()
        self.diag = A.getDiagonal()
        self.scale = self.diag.copy()
        self.scale.abs()

    def destroy(self) -> None:
        """Free every PETSc object."""
        for obj in (self.trial, self.p, self.p0, self.Ap, self.M, self.diag, self.scale, self.F, self.K, self.b,
                    self.g):
            if obj is not None:
                obj.destroy()


class NoShift(RuntimeError):
    """No shift up to the ladder's last |diag A| removed the Jacobian's negative pivots."""


def shifted_solve(ksp: Any, g: Any, p: Any) -> float:
    """The step -K^-1 g into p, K the KSP's factorisation; returns |p|."""
    g.scale(-1.0)
    try:
        ksp.solve(g, p)
    finally:
        g.scale(-1.0)
    return p.norm()


def falls(f: float, ft: float, predicted: float) -> bool:
    """Whether the energy's fall f - ft is at least RHO_KEEP of the model's positive prediction."""
    return predicted > 0 and f - ft >= RHO_KEEP * predicted


def kept(newton: Any, w: Work, f: float, ft: float, predicted: float, rounding: bool, gnorm: float) -> bool:
    """Whether the trial state is kept: the energy's fall against the prediction, or |g| below its rounding.

    ``ft``: the trial's energy, just evaluated (the memo then holds its admissibility); ``rounding``: the step is
    below the energy's rounding (:mod:`suture_fem.solve.trust`), where |g| decides.
    """
    if not newton.memo.admissible:  # the trial's verdict, just made by the objective
        return False
    if not rounding:
        return falls(f, ft, predicted)
    residual = w.Ap  # free after the prediction
    newton._residual(None, w.trial, residual)
    return residual.norm() < gnorm
