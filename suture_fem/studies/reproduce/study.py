"""The study's entry: calibrate (only if asked), solve every cone count, compare, draw, write."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.reproduce.calibration import CALIBRATED, calibrate
from suture_fem.studies.reproduce.compare import comparison, ours, rel
from suture_fem.studies.reproduce.figures import figures
from suture_fem.studies.reproduce.paper import CONES, SCENE, TARGET
from suture_fem.studies.reproduce.report import comparison_markdown
from suture_fem.studies.reproduce.solve import solve_cone_counts, with_values
from suture_fem.support.io import write_json, write_text
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def reproduce(scene: Scene, out: Path, comm: Any, calibrate_again: bool = False,
              pictures: bool = True, scene_name: str = SCENE, cones: tuple[int, ...] = CONES) -> dict[str, Any]:
    """Calibrate (only if asked), solve every cone count, compare, draw; returns comparison.json's content.

    With ``cones`` only a subset of the cone counts is solved: the values of the others are then
    missing from the comparison.
    """
    t_start = time.perf_counter()
    scene, cal = _calibration(scene, comm, out, calibrate_again)
    solved = solve_cone_counts(scene, out, comm, fields=pictures, cones=cones)
    results = solved["results"]
    usum_target = ours(results, TARGET.cones, TARGET.force_n, "usum_mm")[0]
    cal = {**cal, "usum_mm_in_this_run": usum_target}
    if cal["status"] == "from scene":
        cal.update(usum_mm=usum_target, rel_error=rel(usum_target, TARGET.value))
    cmp = comparison(results, cal, scene)
    if pictures:
        cmp["figures"] = [str(p.name) for p in on_root(comm, "drawing the figures", figures, solved, out) or []]
        cmp["figures"] = comm.bcast(cmp["figures"], root=0)
    info = _run_info(scene, scene_name, results, comm, time.perf_counter() - t_start)
    first = next(iter(results.values()), {})
    cmp.update({"scene": scene.as_dict(), "run": info, "stopped": solved["stopped"], "suture_fem_version": first.get(
        "suture_fem_version"), "dolfinx_version": first.get("dolfinx_version")})
    on_root(comm, "writing comparison.json", write_json, out / "comparison.json", cmp)
    on_root(comm, "writing comparison.md", write_text, out / "comparison.md", comparison_markdown(cmp, info))
    return cmp


def _calibration(scene: Scene, comm: Any, out: Path, again: bool) -> tuple[Scene, dict[str, Any]]:
    """The scene to solve and the calibration record: the scene's own value, or a new search (``again``).

    A search that calibrates moves the scene's value (for this run only: the log says where to write
    it to keep it); one that does not keeps the scene's value and records why.
    """
    value = scene.get(CALIBRATED.keys[0])
    if not again:
        return scene, {"status": "from scene", "dimension": CALIBRATED.name, "keys": list(CALIBRATED.keys),
                       "value_mm": value, "why": CALIBRATED.why,
                       "target": {"source": TARGET.source, "cones": TARGET.cones, "force_n": TARGET.force_n,
                                  "usum_mm": TARGET.value}}
    cal = calibrate(scene, comm)
    on_root(comm, "writing calibration.json", write_json, out / "calibration.json", cal)
    if cal["status"] == "calibrated":
        scene = with_values(scene, {k: cal["value_mm"] for k in CALIBRATED.keys})
        log.info("calibrated: %s = %.6g mm; to keep it, write it in suture_fem/scene/builtin/%s.toml",
                 " = ".join(CALIBRATED.keys), cal["value_mm"], SCENE)
    else:
        log.warning("calibration %s: closest USUM %.4f mm at %.4g mm; the scene's %g mm is kept",
                    cal["status"], cal["usum_mm"], cal["value_mm"], value)
    return scene, cal


def _run_info(scene: Scene, scene_name: str, results: dict[int, Any], comm: Any, wall_time_s: float) -> dict[str, Any]:
    """The run as comparison.json records it under ``run``: scene, geometry, mesh, dofs, ranks, wall time."""
    g = scene.as_dict()["geometry"]
    return {
        "scene_name": scene_name,
        "geometry": (f"{g['cone_kind']} cones {g['cone_height_mm']:g} mm high every {g['cone_spacing_mm']:g} mm, "
                     f"thread radius {g['thread_radius_mm']:g} mm, margins {g['margin_far_mm']:g} mm (far) and "
                     f"{g['margin_pull_mm']:g} mm (pulled end)"),
        "mesh": scene.as_dict()["mesh"],
        "dofs": ", ".join(f"{n} cone{'s' if n > 1 else ''}: {r.get('dofs')} dofs" for n, r in results.items()),
        "ranks": comm.size,
        "wall_time_s": wall_time_s,
    }
