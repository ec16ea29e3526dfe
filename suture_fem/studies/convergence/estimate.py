"""``suture-fem run --error-estimate``: one more solve one refinement coarser, and value +- error.

The second solve gives Q_h - Q_2h, and with an assumed order p the estimate is
|Q_h - Q_2h| / (2^p - 1). With p = 1, the default, the estimate is the difference itself, which is
conservative whenever the true order is 1 or more (the ledger, ``suture-fem convergence``, shows the
observed orders).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.convergence.quantities import QUANTITIES, REFINEMENT_RATIO
from suture_fem.studies.convergence.richardson import two_rung_error
from suture_fem.support.io import write_json
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")

_SIZES = ("size_suture_mm", "size_rim_mm", "size_far_mm")


def coarser_scene(scene: Scene) -> Scene:
    """The same scene one refinement coarser (every element size doubled at refinement 0)."""
    mesh = scene.mesh
    if mesh.refinement > 0:
        values: dict[str, Any] = {"mesh.refinement": mesh.refinement - 1}
    else:
        values = {f"mesh.{key}": getattr(mesh, key) * REFINEMENT_RATIO for key in _SIZES}
        values["mesh.fillet_elements"] = max(1, mesh.fillet_elements // int(REFINEMENT_RATIO))  # twice as long
    return scene.with_values({**values, "output.fields": False})


def sharp_corners(results: Mapping[str, Any]) -> list[tuple[float, float]]:
    """Cone corners (mm) that are sharp in this scene.

    All of them, except the base rim corners when ``geometry.cone_fillet_mm`` > 0 rounds them (the
    corners at a cone's base height).
    """
    geometry = results.get("geometry", {})
    corners = [tuple(c) for c in geometry.get("corners_mm", [])]
    if results.get("scene", {}).get("geometry", {}).get("cone_fillet_mm", 0.0) > 0:
        bases = [c["base_z_mm"] for c in geometry.get("cones", [])]
        corners = [c for c in corners if not any(abs(c[1] - z) < 1e-9 for z in bases)]
    return corners


def _entry(rec: dict[str, Any], crec: dict[str, Any], corners: list[tuple[float, float]], exclusion: float,
           order: float) -> dict[str, Any]:
    """Value +- estimate of every quantity at one force; a maximum at a sharp corner gets a note instead."""
    entry: dict[str, Any] = {"force_n": rec["force_n"]}
    for q in QUANTITIES:
        fine, rough = q.of(rec), q.of(crec)
        if fine is None or rough is None:
            continue
        at = q.where(rec)
        averaged = q.path.endswith(("_cd", "_cd_pa"))  # a disc average has a limit wherever its disc is
        if q.path != "usum_mm" and not averaged and at is not None and any(math.dist(at, c) <= exclusion
                                                                            for c in corners):
            entry[q.path] = {"value": fine, "coarse_value": rough, "plus_minus": None, "at_mm": list(at),
                             "note": f"maximum within output.rim_exclusion_mm = {exclusion:g} mm of a sharp cone "
                                     "corner: a singularity, no limit to estimate (use the *_outside_rim "
                                     "measures, or round the rim with geometry.cone_fillet_mm)"}
            continue
        entry[q.path] = {"value": fine, "coarse_value": rough, "plus_minus": two_rung_error(fine, rough, order)}
    return entry


def attach_error_estimate(scene: Scene, results: Mapping[str, Any], comm: Any, out: Path | None = None,
                          order: float = 1.0) -> dict[str, Any]:
    """Solve the scene one refinement coarser; return the JSON form of ``results`` with ``error_estimate``.

    ``results`` itself (read-only) is left as it is. With ``out``, rewrite ``out/results.json`` with
    the returned form (rank 0, atomically).

    For each quantity at each reported force: value +- |Q_h - Q_2h| / (2^p - 1) with the assumed
    order p. The raw maximum stress at a sharp rim has no limit; its entry says so instead.
    """
    from suture_fem.pipeline import run_scene

    coarse_scene = coarser_scene(scene)
    log.info("error estimate: solving the scene once more, one refinement coarser")
    coarse = run_scene(coarse_scene, None, comm)
    corners = sharp_corners(results)
    exclusion = scene.output.rim_exclusion_mm
    estimate: dict[str, Any] = {
        "method": (f"Richardson with an assumed order p = {order:g}: |Q_h - Q_2h| / (2^p - 1), Q_2h from a second "
                   "solve with every element size doubled"),
        "coarse_mesh": {"refinement": coarse_scene.mesh.refinement,
                        "sizes_mm": {k: getattr(coarse_scene.mesh, k) for k in _SIZES},
                        "dofs": coarse.get("dofs"), "wall_time_s": coarse.get("wall_time_s")},
        "at_forces": [],
    }
    for rec in results.get("at_forces", []):
        crec = next((c for c in coarse.get("at_forces", []) if abs(c["force_n"] - rec["force_n"]) < 1e-9), None)
        if crec is not None:
            estimate["at_forces"].append(_entry(rec, crec, corners, exclusion, order))
    last = estimate["at_forces"][-1] if estimate["at_forces"] else None
    if last is not None and "usum_mm" in last:
        u = last["usum_mm"]
        estimate["usum_text"] = f"USUM = {u['value']:.4g} mm +- {u['plus_minus']:.2g} mm at {last['force_n']:g} N"
    attached = {**results, "error_estimate": estimate}
    if out is not None:
        on_root(comm, "writing results.json", write_json, Path(out) / "results.json", attached)
    return attached
