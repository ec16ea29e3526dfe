"""The cones' contact in results.json: its pairs, penalty, search and friction (``effects.interfaces``), its state."""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

from suture_fem.geometry import regions


def notes(contact: Any) -> dict[str, Any]:
    """A :class:`~.cone_contact.ConeContact`'s numbers: its pairs, penalty and search, and (Coulomb) its friction."""
    track, near, watched = (int(v) for v in contact.comm.allreduce(np.array([contact.track.sum(), contact.near.sum(),
                                                                               contact.watched.count])))
    out: dict[str, Any] = {"cone_contact_pairs": int(contact.comm.allreduce(contact.pairs)) - track - near,
                           "cone_contact_penalty_pa_per_m": contact.kappa,
                           "cone_contact_search": "each tissue node's nearest point on its cone's outline, the "
                                                  "outline moved by the cone's mean axial displacement, at "
                                                  "every residual and Jacobian evaluation",
                           "cone_contact_corner_radius_mm": contact.corner_mm,
                           "cone_contact_method": "augmented" if contact.augmented else "penalty"}
    out["cone_contact_next_layer_nodes"] = near + watched
    out["cone_contact_next_layer_search"] = (("the tissue's nodes one element off a cone, each against its nearest "
                                              "cone at rest: unilateral and frictionless") if contact.hold_next_layer
                                             else "the tissue's nodes one element off a cone: measured (how deep "
                                                  "inside its nearest cone the deepest lies), not held off it")
    if contact.corners is not None:
        out["cone_contact_corners"] = contact.corners.count
        held = "held out of the tissue" if contact.held else "measured, not held"
        out["cone_contact_corner_search"] = ("each cone's convex corners (its search outline's arcs' midpoints) "
                                             f"against the tissue's facets on it: {held}")
    if track:
        out["cone_contact_track_nodes"] = track
        out["cone_contact_track_search"] = ("each of the track's tissue nodes against the cone that slides toward "
                                            "it (the nearest whose lower end is at or below the node)")
    if contact.augmented:
        out["contact_penetration_target_mm"] = contact.target / regions.MM
    if contact.convexified:
        out["cone_contact_jacobian"] = ("convexified: the distance's softening curvature left out (P2) where the "
                                        "exact Jacobian has negative pivots")
    if contact.model == "coulomb":
        out.update({"cone_friction_coefficient": contact.mu, "friction_slip_mm": contact.slip / regions.MM})
    return out


def status(contact: Any, u_vec: Any) -> dict[str, Any]:
    """How many nodes on the cones are closed and stick, closed and slip, open; the track's and the next layer's.

    Of the track's and the next layer's, how many are pressed and how deep the deepest lies inside its cone; the
    corners' (:mod:`.cone_corners`) likewise. All ranks'; ``track_pressed_nodes`` only with the track's tissue in
    the search.
    """
    found = contact.search(u_vec)
    closed = contact._pressure(found["phi"])[1]
    stick = closed & (np.abs(found["g"]) < 2.0 * contact.slip) if contact.mu > 0.0 else np.zeros(contact.pairs, bool)
    on, track, near = contact.surface, contact.track, contact.near
    counts = np.array([(stick & on).sum(), (closed & ~stick & on).sum(), (~closed & on).sum(),
                       (closed & track).sum(), track.sum(), (closed & near).sum()])
    stick_n, slip_n, open_n, pressed_n, track_n, near_n = (int(v) for v in contact.comm.allreduce(counts))
    out: dict[str, Any] = {"stick_nodes": stick_n, "slip_nodes": slip_n, "open_nodes": open_n}
    inside = -found["phi"]
    if track_n:  # the track's tissue a cone pushes ahead of it, and how far into the cone the deepest lies
        deepest = float(np.max(inside[track], initial=0.0))
        out["track_pressed_nodes"] = pressed_n
        out["track_penetration_max_mm"] = float(contact.comm.allreduce(deepest, op=MPI.MAX)) / regions.MM
    deepest = max(float(np.max(inside[near], initial=0.0)), contact.watched.depth(u_vec, found["t_c"]))
    out["next_layer_pressed_nodes"] = near_n
    out["next_layer_penetration_max_mm"] = float(contact.comm.allreduce(deepest, op=MPI.MAX)) / regions.MM
    boosted = int(contact.comm.allreduce(int(np.count_nonzero(contact.boost > 1.0))))
    if boosted:  # pairs whose multipliers swapped, their penalty doubled (ConeContact.update)
        out["penalty_boosted_nodes"] = boosted
        out["penalty_boost_max"] = float(contact.comm.allreduce(float(np.max(contact.boost, initial=1.0)), op=MPI.MAX))
    return {**out, **(contact.corners.status(u_vec, found["t_c"]) if contact.corners else {})}
