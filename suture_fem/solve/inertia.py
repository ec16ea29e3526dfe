"""Inertia correction: a Newton step on an energy whose Jacobian has negative pivots gets a shifted Jacobian.

A hyperelastic energy's Jacobian is symmetric, and at a stable equilibrium positive definite. Away
from one it need not be: from rest on the paper scene at P2, the first Newton iterates of the first
load step invert elements next to the sharp cone rims, and the Jacobian there has up to 13 negative
pivots (MUMPS LDL^T reports them). The Newton direction is then not a descent direction of the energy,
and the backtracking line search creeps with steps of a few percent until the Jacobian is positive
definite again (measured: 21 Newton iterations for the first 0.4 N, the Jacobians of 11 of them with
negative pivots; then Newton converges in 9). The remedy of Nocedal & Wright (Numerical Optimization, 2nd ed.,
Algorithm 3.3, "Cholesky with added multiple of the identity"): factorise A + tau D, D = |diag A|,
with tau = 1e-4, 1e-3, ... until the factorisation has no negative pivot, and take the Newton step
with that. Only the iterates with negative pivots are touched; near a stable equilibrium the Jacobian
is positive definite, so Newton's quadratic convergence and the converged state are unchanged. Near an
equilibrium whose Jacobian has a negative pivot (a saddle of the energy: measured on one ramp, docs/speed.md)
the shifted steps lead elsewhere, to a state without one. Where the line search works on the residual
norm (degree 2) the correction is not a descent guarantee: the line search's slope is the shifted
model's; the gains there are measured, not proven.

In parallel, MUMPS reports the inertia of the root front only without ScaLAPACK (ICNTL(13) = 1), which
:class:`~suture_fem.solve.newton.NewtonSolver` sets when it runs on several ranks with the correction on.

Hand-written because PETSc 3.18's SNES has no such option for an external factorisation (its
``pc_factor_shift_type`` applies to PETSc's own factorisations only), and it needs MUMPS's inertia
(INFOG(12), the number of negative pivots of a symmetric factorisation); used only where the Jacobian
is factorised by MUMPS LDL^T (static, plain displacement scenes).
"""

from __future__ import annotations

import logging
from typing import Any

from petsc4py import PETSc

log = logging.getLogger("suture_fem")

#: The first shift (times |diag A|) and the factor between tries; at most MAX_TRIES tries.
FIRST_SHIFT, SHIFT_GROWTH, MAX_TRIES = 1e-4, 10.0, 8
#: The shifts tried, FIRST_SHIFT x SHIFT_GROWTH^k, and the KSP attribute that keeps the k its last correction took.
SHIFTS = [FIRST_SHIFT * SHIFT_GROWTH**k for k in range(MAX_TRIES)]
LAST_SHIFT = "suture_fem_inertia_shift"


def negative_pivots(ksp: Any) -> int | None:
    """Negative pivots of the factorisation the KSP made last (MUMPS LDL^T); None if it failed or is not MUMPS's."""
    try:
        factor = ksp.getPC().getFactorMatrix()
        if factor.getMumpsInfog(1) < 0:
            return None
        return int(factor.getMumpsInfog(12))
    except PETSc.Error:
        return None


def _factorise(ksp: Any, A: Any) -> int | None:
    """Factorise A now: its negative pivots, or None if the factorisation failed.

    After a failure the PC is set up afresh at the next try: PETSc's MUMPS interface does not factorise
    again after a failed factorisation.
    """
    ksp.getPC().setUp()
    negative = negative_pivots(ksp)
    if negative is None:
        ksp.getPC().reset()
        ksp.setOperators(A, A)
    return negative


def positive_definite(ksp: Any, A: Any) -> bool:
    """Factorise A now; whether the factorisation succeeded with no negative pivot (it is then the KSP's)."""
    ksp.setOperators(A, A)
    return _factorise(ksp, A) == 0


def correct(ksp: Any, A: Any) -> tuple[bool, int]:
    """Factorise A (the reduced Jacobian) now; while it has negative pivots, shift its diagonal and factorise again.

    Returns (whether A was left shifted, the extra factorisations made). The factorisation left in the
    KSP is that of the A returned, so SNES's own set-up does not factorise again. A shift whose
    factorisation fails (it made A singular) counts as a try; if none of :data:`MAX_TRIES` leaves a
    factorisation without negative pivots, A is restored and factorised as it was. A failure of the
    first factorisation, of A itself, is left to SNES, as without the correction.

    The shift taken is the smallest of FIRST_SHIFT x SHIFT_GROWTH^k without negative pivots. A + tau D
    grows with tau (D >= 0), so its negative pivots can only fall as tau grows: the search starts one
    below the shift the KSP's last correction took (kept on the KSP) and goes up, or, where that one
    already has none, down until one has some; the shift found is the same, in fewer factorisations
    (Jacobians in a row of a Newton solve need about the same shift).
    """
    ksp.setOperators(A, A)
    ksp.getPC().setUp()
    negative = negative_pivots(ksp)
    if not negative:
        return False, 0
    original = A.getDiagonal()
    scale = original.copy()
    scale.abs()
    k, extra = smallest_shift(ksp, A, original, scale, SHIFTS, max(0, (ksp.getAttr(LAST_SHIFT) or 0) - 1))
    failed = k is None
    shift = SHIFTS[-1] if k is None else SHIFTS[k]
    if failed:  # no shift helped: the Jacobian as it was
        A.setDiagonal(original)
        _factorise(ksp, A)
        extra += 1
        log.info("inertia correction: no shift up to %.0e |diag A| removed every negative pivot; the Newton step "
                 "uses the indefinite Jacobian", shift)
    else:
        ksp.setAttr(LAST_SHIFT, k)
        log.debug("inertia correction: %d factorisations, shift %.0e |diag A|", extra, shift)
    original.destroy()
    scale.destroy()
    return not failed, extra


def smallest_shift(ksp: Any, A: Any, original: Any, scale: Any, shifts: list[float], start: int,
                   down: bool = True) -> tuple[int | None, int]:
    """The index of the smallest of ``shifts`` whose A (diagonal original + shift x scale) has no negative pivot.

    Searched from ``start``: up while the factorisation has negative pivots (or fails), else (``down``) down while
    it has none; without ``down`` the start is taken where it has none. A is left shifted by the shift found and
    its factorisation in the KSP (whose operator A must be); None when none of them has none (A left shifted by
    the last). Returns (index or None, factorisations made).
    """
    k = start
    negative, extra = _shifted(ksp, A, original, scale, shifts[k]), 1
    while (negative is None or negative > 0) and k < len(shifts) - 1:  # None: a shift made it singular, go on
        k += 1
        negative, extra = _shifted(ksp, A, original, scale, shifts[k]), extra + 1
    if negative is None or negative > 0:
        return None, extra
    if extra == 1 and down:  # the first one tried already had none: the smaller ones, while they have none
        while k > 0:
            lower, extra = _shifted(ksp, A, original, scale, shifts[k - 1]), extra + 1
            if lower is None or lower > 0:
                _shifted(ksp, A, original, scale, shifts[k])
                extra += 1
                break
            k -= 1
    return k, extra


def shifted_definite(ksp: Any, A: Any, original: Any, scale: Any, shift: float) -> bool:
    """Make A's diagonal original + shift x scale and factorise it now (as the KSP's operator): no negative pivot?"""
    ksp.setOperators(A, A)
    return _shifted(ksp, A, original, scale, shift) == 0


def _shifted(ksp: Any, A: Any, original: Any, scale: Any, shift: float) -> int | None:
    """Factorise A with the diagonal original + shift x scale: its negative pivots (None: failed)."""
    shifted = original.copy()
    shifted.axpy(shift, scale)
    A.setDiagonal(shifted)
    shifted.destroy()
    return _factorise(ksp, A)
