"""The cones' side of the interface output when the cones are not tied (``effects.cone_interface``).

Per tissue node on a cone (:class:`~suture_fem.physics.effects.cone_contact.ConeContact`'s pairs): the gap
(mm; positive: the tissue has lifted off the cone there; negative: the penalty's penetration) and the slip
(mm; how far the cone has slid past the tissue along its surface, positive toward the pull). Per cone: the
largest slip, opening and penetration, and the arc-length ranges where the tissue has separated, with how
many nodes are closed (sticking or slipping under Coulomb friction) and open.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from suture_fem.geometry import regions
from suture_fem.geometry.regions import TISSUE_REGIONS, WHOLE_TISSUE
from suture_fem.support import compat

#: A node counts as separated when its gap exceeds this (mm): 0.1 um, far below an element (50-150 um) and
#: above a closed node's penalty penetration's sign noise.
SEPARATION_MM = 1e-4
#: A report warns when the tissue's next layer, only measured (the thread tied), lies deeper than this inside a
#: cone, or a cone's corner, only measured, inside the tissue's facets (mm): a tenth of the tissue's elements at
#: the cones (about 46 um at P1).
DEPTH_WARNING_MM = 5e-3

log = logging.getLogger("suture_fem")


def cone_nodes(physics: Any, nodes: np.ndarray) -> dict[str, np.ndarray]:
    """``cone_gap``, ``cone_slip`` (mm) at the interface output's owned ``nodes`` (0 off the pairs; collective)."""
    contact = physics.cone_contact
    found = contact.search(compat.function_vector(physics.state))  # the gap phi (positive: open), the slip g
    profile = {"gap_mm": found["phi"] / regions.MM, "slip_mm": found["g"] / regions.MM}
    where = {int(n): k for k, n in enumerate(contact.nodes) if contact.surface[k]}  # the cones' own surfaces
    index = np.array([where.get(int(n), -1) for n in nodes], dtype=np.int64)
    paired = index >= 0
    out = {}
    for key, name in (("cone_gap", "gap_mm"), ("cone_slip", "slip_mm")):
        values = np.zeros(len(nodes))
        values[paired] = profile[name][index[paired]]
        out[key] = values
    out["cone_pair"] = paired
    return out


def cone_record(physics: Any, profiles: dict[str, Any], names: list[str]) -> dict[str, Any]:
    """``cone_contact``: each cone's largest slip, opening, penetration, separated arc ranges; node counts."""
    per_cone = {}
    for name in names[:-1]:
        prof = profiles[name]
        gap = np.asarray(prof.get("gap_mm", []), dtype=float)
        slip = np.asarray(prof.get("slip_mm", []), dtype=float)
        s = np.asarray(prof["s_mm"], dtype=float)
        per_cone[name] = {
            "slip_max_mm": float(np.max(np.abs(slip))) if len(slip) else 0.0,
            "opening_max_mm": float(max(np.max(gap), 0.0)) if len(gap) else 0.0,
            "penetration_max_mm": float(max(-np.min(gap), 0.0)) if len(gap) else 0.0,
            "separated_s_mm": intervals(s, gap > SEPARATION_MM),
        }
    contact = physics.cone_contact
    state = compat.function_vector(physics.state)
    if contact.corners is not None:  # how deep each cone's deepest corner lies inside the tissue's facets
        for name, depth in zip(names, contact.corners.depths(state, contact.search(state)["t_c"])):
            per_cone[name]["corner_penetration_max_mm"] = depth
    record: dict[str, Any] = {"model": contact.model, **contact.status(state), "cones": per_cone}
    depth = record["next_layer_penetration_max_mm"]
    if not contact.hold_next_layer and depth > DEPTH_WARNING_MM and physics.comm.rank == 0:
        log.warning("the tissue's next layer lies %.3g mm inside a cone (measured, not held with the thread tied: "
                    "docs/contact.md, \"The tissue's next layer in the search\")", depth)
    corner = record.get("corner_penetration_max_mm", 0.0)
    if contact.held is None and corner > DEPTH_WARNING_MM and physics.comm.rank == 0:
        log.warning("a cone's corner lies %.3g mm inside the tissue's facets (measured, not held: effects.cone_corners "
                    "= \"held\" holds it, docs/contact.md \"The cones' corners against the tissue's facets\")", corner)
    if contact.mu > 0.0:
        record["coulomb_residual_n"] = contact.residual()
    return {"cone_contact": record}


def maxima_near_cut_corners(record: dict[str, Any], contact: Any, state: Any, radius_mm: float) -> list[dict[str, Any]]:
    """The tissue's maxima in ``record`` lying near a cone's corner that cuts the tissue (collective).

    A corner cuts when it lies more than DEPTH_WARNING_MM inside the tissue's facets
    (:mod:`~suture_fem.physics.effects.cone_corners`). A stress or strain maximum (``<name>_at_mm``, a reference
    place, in a tissue region; not USUM) is near it within ``radius_mm`` (the critical distance) plus the corner's
    depth of the tissue the corner cuts, taken where that tissue was at rest (the nearest point of its facet, which
    may have slid far round the corner). Per such maximum: the cone, that tissue's reference place, the distance and
    the corner's depth (mm). ``state``: the state's PETSc vector.
    """
    cut = contact.corners.cut(state, contact.search(state)["t_c"], DEPTH_WARNING_MM)
    out: list[dict[str, Any]] = []
    for key, at in record.items() if cut else []:
        name = key[: -len("_at_mm")]
        if (not key.endswith("_at_mm") or at is None or name.startswith("usum")  # the stress and strain maxima
                or record.get(name + "_region") not in (*TISSUE_REGIONS, WHOLE_TISSUE)):
            continue
        distance = [float(np.linalg.norm(tissue - np.asarray(at, dtype=float)[:2])) for _, _, tissue in cut]
        k = int(np.argmin(distance))
        cone, depth, tissue = cut[k]
        if distance[k] <= radius_mm + depth:
            out.append({"measure": name, "cone": f"cone_{cone + 1}", "tissue_at_mm": [float(v) for v in tissue],
                        "distance_mm": distance[k], "corner_penetration_mm": depth})
    if out and contact.comm.rank == 0:
        log.warning("the tissue's maxima %s lie near a cone's corner that cuts the tissue (up to %.3g mm inside its "
                    "facets): not resolved there (docs/contact.md, \"The cones' corners against the tissue's facets\")",
                    ", ".join(item["measure"] for item in out), max(item["corner_penetration_mm"] for item in out))
    return out


def intervals(z: np.ndarray, open_: np.ndarray) -> list[list[float]]:
    """The ranges (mm) of consecutive open nodes along an ordered coordinate, [first, last] of each run."""
    out: list[list[float]] = []
    start = None
    for k in range(len(z)):
        if open_[k] and start is None:
            start = k
        if start is not None and (k == len(z) - 1 or not open_[k + 1]):
            out.append([float(z[start]), float(z[k])])
            start = None
    return out
