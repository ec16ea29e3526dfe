"""Contact of the tissue with a frictionless thread that it may leave (``effects.thread_interface = "frictionless"``).

The tissue's side of the thread's track (its own nodes, facets tagged ``track``: the mesh is split as
for a sliding thread) may move away from the thread but not into it. The thread's surface is taken as
the track r = r_t itself (its radial Poisson contraction, at most nu F / (pi r_t E), is neglected as
for the sliding thread), so the gap at a track point is its radial displacement u_r and the
non-penetration condition is u_r >= 0, wherever along the thread the point has slid: no search. In 3-D (the
half model, the thread along y) u_r = u . e_r with e_r = (x, 0, z) / sqrt(x^2 + z^2), the outward radial unit vector
off the thread's axis at the track point's reference position.

The condition is imposed by a penalty (Wriggers, Computational Contact Mechanics, 2006, ch. 6),

    Pi_c = 1/2 kappa int <-u_r>^2 2 pi r ds_track,   <x> = max(x, 0),

whose variation gives the contact pressure p = kappa <-u_r> (zero where the tissue has opened). The
stiffness is kappa = ``effects.contact_penalty`` x K0 / h, with K0 = 2 (1/d1) the hypodermis's initial
bulk modulus (times ``materials.tissue_scale``) and h the element size on the suture's surface: the
scaling CONTACT.md recommends (about E / h). The residual penetration is p / kappa, reported by the
interface output as ``track_penetration_max_mm``. The penalty's energy joins the potential, so the
line search's energy objective and the Jacobian (its exact derivative, piecewise: semismooth Newton)
see it.
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import ufl
from petsc4py import PETSc

from suture_fem.geometry.regions import MM, Facet
from suture_fem.physics.forms import FormContext, Terms
from suture_fem.scene.model import Scene


def penalty_stiffness(scene: Scene, suture_size_mm: float, factor: float | None = None) -> float:
    """Kappa (Pa/m): ``factor`` (``effects.contact_penalty``) x the hypodermis's initial bulk modulus / element size.

    The element size is the suture's; ``factor`` None takes ``effects.contact_penalty``.
    """
    hyp = scene.materials.hypodermis.params
    inv_d = hyp.get("inv_d1", hyp.get("inv_d", 0.0))
    bulk = 2.0 * float(inv_d) * scene.materials.tissue_scale
    if bulk <= 0.0:  # an incompressible hypodermis (1/d = 0, mixed): its initial shear modulus instead
        bulk = 2.0 * float(hyp.get("c10", hyp.get("mu", 1.0))) * scene.materials.tissue_scale
    factor = scene.effects.contact_penalty if factor is None else factor
    return factor * bulk / (suture_size_mm * MM)


def contact_term(ctx: FormContext, kappa: float, terms: Terms) -> None:
    """The penalty's potential on the track, added to ``terms`` as ``contact:thread``."""
    mesh = ctx.w.function_space.mesh
    stiffness = dolfinx.fem.Constant(mesh, PETSc.ScalarType(kappa))
    ur = radial(ctx.u, ctx.x)
    closed = ufl.conditional(ufl.lt(ur, 0.0), ur, 0.0)
    terms.potential["contact:thread"] = 0.5 * stiffness * closed**2 * ctx.weight * ctx.ds(int(Facet.TRACK))


def radial(u: Any, x: Any) -> Any:
    """U_r: u's first component in 2-D; in 3-D u . (x, 0, z) / sqrt(x^2 + z^2) (the thread's axis is y)."""
    if len(x) == 2:
        return u[0]
    return (u[0] * x[0] + u[2] * x[2]) / ufl.sqrt(x[0] ** 2 + x[2] ** 2)


def cones_augmented(section: Any) -> bool:
    """The cones' contact of ``section`` (a scene's ``[effects]``) is an augmented Lagrangian's.

    Only a unilateral one: the bilateral ("sliding") cones keep the pure penalty (their multipliers'
    first update stopped the paper scene's ramp below 0.1 N, at one cone and at four, docs/contact.md).
    """
    return section.cone_contact_method == "augmented" and section.cone_interface != "sliding"
