"""The cones' contact in results.json's ``effects.interfaces``: its pairs, penalty, search and friction."""

from __future__ import annotations

from typing import Any

import numpy as np

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
    if track:
        out["cone_contact_track_nodes"] = track
        out["cone_contact_track_search"] = ("each of the track's tissue nodes against the cone that slides toward "
                                            "it (the nearest whose lower end is at or below the node)")
    if contact.augmented:
        out["contact_penetration_target_mm"] = contact.target / regions.MM
    if contact.convexified:
        out["cone_contact_jacobian"] = "convexified: the distance's softening curvature left out (P2)"
    if contact.model == "coulomb":
        out.update({"cone_friction_coefficient": contact.mu, "friction_slip_mm": contact.slip / regions.MM})
    return out
