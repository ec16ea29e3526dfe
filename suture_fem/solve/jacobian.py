"""The full Jacobian A = dR/du before the reduction: the forms' part and the hand-assembled nodal terms'.

The nodal terms (:func:`~suture_fem.physics.effects.friction.nodal_terms`: a Coulomb thread's friction, the
cones' contact) couple nodes that share no cell, so UFL cannot assemble them; each adds its Hessian at the
current state, with what it holds between Newton solves (the Coulomb bound, the augmented Lagrangian's
multipliers) frozen. The Newton solver (:mod:`suture_fem.solve.newton`) and the calibration's sensitivities
(:mod:`suture_fem.studies.calibrate.sensitivity`) both assemble A here.

A Newton solve wants the frozen terms: they are what it solves. A sensitivity wants the derivative of the
settled state, where the augmented Lagrangian's multipliers have followed the state until every pressed
node lies on its cone (to ``effects.contact_penetration_mm``): to first order a pressed node then keeps its
distance, and the frozen multipliers' tangent (the penalty kappa on the pressed nodes) is too soft by
about k / kappa, k the tissue's local stiffness (measured: 1.1e-4 of dUSUM/dtissue_scale at one
frictionless cone, 0.5 N). ``settled=True`` assembles the constraint's penalty limit: the pressed nodes'
penalty multiplied by :data:`SETTLED_STIFFENING`, their pressure unchanged (the multiplier shifted by the
same amount), which the terms' own assembly takes as it is.

The cones' convexified terms (P2 unilateral cones, ``ConeContact._hessian``) leave out a pressed node's softening
beside a convex arc of a cone's outline. Where the Jacobian stays positive definite with it, the Newton solver
takes the exact one (:func:`exact_kept`): without the term, a pressed node on the apex corner's rounding gave
Newton a linear rate (the residual x 0.8 per iterate) and the ramps stalled there (docs/contact.md, "P2 cones").
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import dolfinx.fem.petsc
import numpy as np
from mpi4py import MPI

from suture_fem.physics.effects.friction import nodal_terms
from suture_fem.support import compat

#: The pressed nodes' penalty of a settled augmented Lagrangian, in units of its own (dUSUM/dtissue_scale at
#: one frictionless cone, 0.5 N: 1.1e-4 from the two solves' central difference unstiffened, 1.3e-7 at 1e4).
SETTLED_STIFFENING = 1e4


def create(problem: Any, J_form: Any) -> Any:
    """The full Jacobian's matrix of ``problem``, with room for every nodal term's couplings."""
    A = dolfinx.fem.petsc.create_matrix(J_form)
    nodal = nodal_terms(problem)
    if nodal:  # the forms' pattern in place before the nodal terms widen it (pattern.widen keeps it)
        dolfinx.fem.petsc.assemble_matrix(A, J_form)
        A.assemble()
    for terms in nodal:
        terms.extend_pattern(A)
    return A


def follows_state(problem: Any) -> bool:
    """Whether a settled state's derivative differs from the frozen terms' (an augmented Lagrangian's multipliers)."""
    return any(getattr(terms, "augmented", False) for terms in nodal_terms(problem))


def assemble(problem: Any, J_form: Any, A: Any, settled: bool = False) -> None:
    """A = dR/du at ``problem``'s current state: the form, then every nodal term (collective).

    ``settled``: the augmented Lagrangian's pressed nodes held on their cones (the module docstring).
    """
    A.zeroEntries()
    dolfinx.fem.petsc.assemble_matrix(A, J_form)
    A.assemble()
    u_vec = compat.function_vector(problem.state)
    for terms in nodal_terms(problem):
        if settled and getattr(terms, "augmented", False):
            with _stiffened(terms, u_vec):
                terms.add_jacobian(u_vec, A)
        else:
            terms.add_jacobian(u_vec, A)


def exact_kept(problem: Any, assemble: Callable[[], None], positive_definite: Callable[[], bool]) -> bool:
    """Whether the exact Jacobian was assembled and factorised with no negative pivot (collective).

    Tried only where the cones' convexified terms (P2 unilateral cones) leave out a pressed node's softening
    beside a convex arc; ``assemble`` assembles the Jacobian, ``positive_definite`` factorises it. False: the
    caller assembles the convexified one.
    """
    contact = getattr(problem, "cone_contact", None)
    if contact is None or not contact.convexified:
        return False
    found = contact.search(compat.function_vector(problem.state))
    here = bool(np.any((contact.pressure() > 0.0) & (found["curvature"] > 0.0)))
    if not problem.comm.allreduce(here, op=MPI.LOR):
        return False
    with exact(problem):
        assemble()
    return positive_definite()


@contextmanager
def exact(problem: Any) -> Iterator[None]:
    """Inside: the cones' terms assemble their exact Jacobian (the convexified one's softening included)."""
    contact = getattr(problem, "cone_contact", None)
    kept = None if contact is None else contact.convexified
    if contact is not None:
        contact.convexified = False
    try:
        yield
    finally:
        if contact is not None:
            contact.convexified = kept


@contextmanager
def _stiffened(terms: Any, u_vec: Any) -> Iterator[None]:
    """The cones' penalty x :data:`SETTLED_STIFFENING`, every node's pressure and open or pressed status kept.

    p = <lambda - kappa phi>: on a pressed node lambda moves to p + kappa' phi; an open node (lambda - kappa
    phi <= 0, so phi >= 0) stays open under the larger kappa'.
    """
    kappa, multiplier = terms.kappa, terms.multiplier
    phi = terms.search(u_vec)["phi"]
    trial = multiplier - getattr(terms, "penalty", kappa) * phi  # the cones' penalty: kappa x each pair's boost
    terms.kappa = kappa * SETTLED_STIFFENING
    terms.multiplier = np.where(trial > 0.0, trial + getattr(terms, "penalty", terms.kappa) * phi, multiplier)
    try:
        yield
    finally:
        terms.kappa, terms.multiplier = kappa, multiplier
