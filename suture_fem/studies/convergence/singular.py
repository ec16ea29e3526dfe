"""The model's singular points, the tissue's maxima away from them, and one ledger rung's solve.

A maximum taken at a singular point (a sharp cone corner, a bonded material interface or a change
of boundary condition meeting a free boundary) has no limit under refinement; a maximum taken
farther than a fixed distance from every singular point has one. ``suture-fem ledger-rung`` is
``suture-fem run`` plus those maxima at every reported force.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.convergence.quantities import SINGULAR_FREE_MM, beyond
from suture_fem.support.io import write_json
from suture_fem.support.parallel import on_root


def singular_points(geometry: Any, fillet_mm: float) -> list[tuple[float, float]]:
    """Every point (mm) where the elastic field of the model is singular.

    The sharp cone corners (the base rim corners are not, when ``geometry.cone_fillet_mm`` > 0 rounds
    them), every point where a cone's outline meets the thread surface, and every point where an
    interface or the clamped outer surface meets a free end face of the tissue (z = 0 and z = L): the
    thread surface, the hypodermis-dermis and dermis-epidermis interfaces and the clamped surface
    r = r_epidermis. At each, a re-entrant corner, a bonded material interface or a change of
    boundary condition meets a free boundary.
    """
    r_t = geometry.r_thread
    points = list(geometry.corners)
    if fillet_mm > 0:
        points = [p for p in points if not any(abs(p[1] - c.base_z) < 1e-9 for c in geometry.cones)]
    for cone in geometry.cones:
        for _, segment in cone.outline:
            points += [tuple(q) for q in segment if abs(q[0] - r_t) < 1e-9 and tuple(q) not in points]
    radii = (r_t, geometry.r_hypodermis, geometry.r_dermis, geometry.r_epidermis)
    return points + [(r, z) for r in radii for z in (0.0, geometry.length)]


def singular_free_maxima(outputs: Any, fillet_mm: float) -> dict[str, Any]:
    """The tissue's maximum von Mises stress and equivalent strain away from every singular point.

    The maxima are cell maxima over quadrature points, over the cells whose midpoint is farther than
    each of :data:`SINGULAR_FREE_MM` from every singular point (collective). A maximum taken away from
    every singularity has a limit.
    """
    import dolfinx.mesh
    import numpy as np

    from suture_fem.geometry import mesh as meshmod
    from suture_fem.geometry import regions

    physics = outputs.physics
    mesh, comm = physics.mesh, physics.comm
    points = np.array(singular_points(physics.tagged.geometry, fillet_mm), dtype=float).reshape(-1, 2)
    cells = meshmod.region_cells(physics.tagged, regions.TISSUE)
    cells = cells[cells < mesh.topology.index_map(mesh.topology.dim).size_local]
    mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, cells)[:, :2] / regions.MM
    dist = np.min(np.linalg.norm(mid[:, None, :] - points[None, :, :], axis=2), axis=1) if len(cells) else mid[:, 0]
    fields = outputs.cell_maxima()
    out: dict[str, Any] = {"singular_points_mm": points.tolist()}
    for d in SINGULAR_FREE_MM:
        far = dist > d
        for name, key in (("seqv_pa", "von_mises_pa"), ("eptoeqv", "eptoeqv")):
            vals = fields[key][cells[far]]
            k = int(np.argmax(vals)) if len(vals) else -1
            local = (float(vals[k]), mid[far][k].tolist()) if k >= 0 else (-np.inf, None)
            value, at = max(comm.allgather(local), key=lambda t: t[0])
            out[f"tissue_{name}_beyond_{beyond(d)}"] = value if at is not None else None
            out[f"tissue_{name}_beyond_{beyond(d)}_at_mm"] = at
    return out


def solve_rung(scene: Scene, folder: Path | None, comm: Any) -> dict[str, Any]:
    """A Model's solve plus, at every reported force's state, the singularity-free maxima under ``ledger``.

    Returns the JSON form of the results with them (``at_forces[].ledger``); results.json is
    rewritten with them (rank 0).
    """
    from suture_fem.pipeline import scene_model

    model = scene_model(scene, folder, comm)
    results = {**model.solve(folder)}  # a plain dict: the Results are read-only
    extra: dict[float, dict[str, Any]] = {}
    if {"seqv", "eptoeqv"} <= set(model.outputs.quantities):
        fillet = scene.geometry.cone_fillet_mm
        extra = {report.force_n: singular_free_maxima(model.outputs, fillet) for report in model.reports()}
    results["at_forces"] = [{**rec, "ledger": extra[rec["force_n"]]} if rec["force_n"] in extra else rec
                            for rec in results.get("at_forces", [])]
    if folder is not None:
        on_root(comm, "writing results.json", write_json, Path(folder) / "results.json", results)
    return results
