"""The trust region's step along negative curvature (Moré and Sorensen's hard case).

Where the Jacobian A has a negative eigenvalue the trust region's step p = -(A + lam D)^-1 g is taken at a shift
lam at least lam0, the smallest rung of a ladder of tenfold shifts whose factorisation has no negative pivot
(:mod:`suture_fem.solve.trust`). That rung can lie up to ten times above the shift that removes the negative
eigenvalue, and then p falls well inside the radius: the model's minimiser on the ball lies on its boundary
(the model is not convex), but the step stops short of it. On the P2 cones such steps were a third of the trust
region's iterations, each moving the state a few micrometres while the residual stayed where it was.

Moré and Sorensen (1983; Nocedal and Wright, Numerical Optimization, 2nd ed., section 4.3, "the hard case")
complete such a step along z, the eigenvector of the most negative eigenvalue, to the boundary: p + tau z with
|p + tau z| = delta (here at most :data:`STRETCH` |p|), of tau's two roots the one whose model value is lower,
and p as it is where neither lowers it (here the model also holds the cones' open pairs, whose penalty a long
step along z may press). z comes from inverse iteration on the factorisation already made (of A + lam D,
positive definite), whose largest eigenvalue 1 / (lam + theta) belongs to the pencil's lowest, theta; it starts
from p (the shifted solve has already amplified that direction) and takes :data:`INVERSE_ITERATIONS` solves, no
factorisation. It is used only where its Rayleigh quotient theta = z.A z / z.D z is negative; the trust region's
energy test decides, as for every step.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

#: Solves of the inverse iteration for the lowest eigenvector of (A, D) (each one triangular solve pair).
INVERSE_ITERATIONS = 4
#: A step shorter than this fraction of the radius is completed to it.
INTERIOR = 0.9
#: ... but to at most this many times its own length: z is local (a few nodes beside a cone's rim), and the radius,
#: earned by steps that move the whole tissue, let it invert elements at once (the P2 cones: 5-6 refusals each time).
STRETCH = 4.0


def to_boundary(ksp: Any, A: Any, scale: Any, g: Any, p: Any, delta: float,
                extra: Callable[[Any], float]) -> tuple[float, float]:
    """Complete the interior step ``p`` (in place) along A's negative curvature to |p| = min(delta, STRETCH |p|).

    ``ksp`` holds a positive definite factorisation of A + lam D (lam > 0, D = ``scale``), or of the same with the
    trust region's joined pairs' terms, which only add to A; ``extra(p)``: the model's terms besides
    g.p + p.A p / 2 (the open pairs' penalty). Of p and its two completions the one of lowest model value is kept.
    Returns (|p|, theta): theta >= 0 where (A, D) shows no negative curvature along the iteration's direction, and
    then p unchanged; theta = 0 where p was not completed for its length (collective).
    """
    norm = p.norm()
    reach = min(delta, STRETCH * norm)
    if norm >= INTERIOR * reach or norm == 0.0:
        return norm, 0.0
    z, y, Az = p.duplicate(), p.duplicate(), p.duplicate()
    try:
        p.copy(z)
        z.scale(1.0 / norm)
        for _ in range(INVERSE_ITERATIONS):
            y.pointwiseMult(scale, z)
            ksp.solve(y, z)
            size = z.norm()
            if not np.isfinite(size) or size == 0.0:
                return norm, 0.0
            z.scale(1.0 / size)
        A.mult(z, Az)
        y.pointwiseMult(scale, z)
        theta = z.dot(Az) / z.dot(y)
        if theta >= 0.0:
            return norm, theta
        b, c = p.dot(z), norm * norm - reach * reach  # |p + tau z|^2 = reach^2, |z| = 1
        root = np.sqrt(b * b - c)
        A.mult(p, y)
        slope = g.dot(z) + y.dot(z)  # the quadratic part: m(p + tau z) - m(p) = tau slope + tau^2 z.A z / 2
        curve = z.dot(Az)

        def change(tau: float) -> float:
            y.waxpy(tau, z, p)
            return tau * slope + 0.5 * tau * tau * curve + extra(y)

        tau = min((0.0, -b + root, -b - root), key=change)
        if tau == 0.0:
            return norm, theta
        p.axpy(tau, z)
        return p.norm(), theta
    finally:
        for v in (z, y, Az):
            v.destroy()
