"""The study's entry: calibrate one parameter on one value, solve every cone count, compare, draw, write."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from suture_fem.pipeline import with_values
from suture_fem.scene import Scene
from suture_fem.studies.calibrate.keys import DIRECT
from suture_fem.studies.paper import CONES, SCENE, TARGET
from suture_fem.studies.reproduce.calibration import DEFAULT, calibrate, not_calibrated, parse_key
from suture_fem.studies.reproduce.compare import comparison, findings, missing_values, ours
from suture_fem.studies.reproduce.figures import figures
from suture_fem.studies.reproduce.report import comparison_markdown
from suture_fem.studies.reproduce.rungs import RUNGS
from suture_fem.studies.reproduce.solve import case_scene, cpu_self, solve_cone_counts
from suture_fem.studies.reproduce.stress import stress_comparison
from suture_fem.support.io import write_json, write_text
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def reproduce(scene: Scene, out: Path, comm: Any, calibrate_key: str = DEFAULT, pictures: bool = True,
              scene_name: str = SCENE, cones: tuple[int, ...] = CONES, max_evaluations: int = 20,
              fixed: frozenset[str] | None = frozenset(), jobs: int = 1, estimates: bool = True) -> dict[str, Any]:
    """Calibrate one key on one value, solve every cone count, compare, draw; returns comparison.json's content.

    ``calibrate_key``: ``KEY[=LOW:HIGH]`` fitted to USUM 4.0 mm at 4 cones, 1 N (then the scene is also
    solved as it is, for the uncalibrated column, under ``out/uncalibrated``), or ``none``. With
    ``cones`` only a subset of the cone counts is solved: the values of the others are then missing.
    Each cone count is solved on its mesh rung (:mod:`~suture_fem.studies.reproduce.rungs`; the
    calibration on the 4-cone one) but for the mesh keys in ``fixed`` (the user's); ``fixed`` None:
    the scene's own mesh for all. ``jobs``: ramps solved at once in child processes (1: in this
    process). ``estimates``: attach each USUM's estimated discretisation error where the case is
    solved on its rung (False when the scene is not the built-in one the rungs were measured on).
    """
    t_start, cpu_start = time.perf_counter(), cpu_self(children=True)
    key = parse_key(calibrate_key, scene)
    cal = not_calibrated(scene) if key is None else calibrate(
        case_scene(scene, TARGET.cones, fixed), comm, key, out / "calibration", max_evaluations)
    uncalibrated, cpu = None, 0.0
    if cal["status"] == "calibrated":
        before = solve_cone_counts(scene, out / "uncalibrated", comm, fields=False, cones=cones, fixed=fixed,
                                   jobs=jobs)
        uncalibrated, cpu = before["results"], before["cpu_time_s"]
        scene = with_values(scene, {key.key: cal["value"]})
    solved = solve_cone_counts(scene, out, comm, fields=pictures, cones=cones, band=_band(cal), fixed=fixed,
                               jobs=jobs)
    results = solved["results"]
    cal["usum_mm_in_this_run"] = ours(results, TARGET.cones, TARGET.force_n, "usum_mm")[0]
    cmp = comparison(results, cal, scene, uncalibrated=uncalibrated, bands=solved["bands"],
                     errors=_estimates(solved, cones) if estimates else None)
    # the converging measures, as solved and uncalibrated, with their error bars
    cmp["stress"] = stress_comparison(results, uncalibrated=uncalibrated) if {2, 4} <= set(results) else None
    if pictures:
        cmp["figures"] = [str(p.name) for p in on_root(comm, "drawing the figures", figures, solved, out) or []]
        cmp["figures"] = comm.bcast(cmp["figures"], root=0)
    info = _run_info(scene, scene_name, results, comm, time.perf_counter() - t_start)
    info.update({"jobs": solved["jobs"], "rungs": {str(n): _rung_label(m) for n, m in solved["rungs"].items()},
                 "ramps_cpu_time_s": cpu + solved["cpu_time_s"], "cpu_time_s":
                     comm.allreduce(cpu_self(children=True) - cpu_start)})
    first = next(iter(results.values()), {})
    cmp.update({"scene": scene.as_dict(), "run": info, "stopped": solved["stopped"], "suture_fem_version": first.get(
        "suture_fem_version"), "dolfinx_version": first.get("dolfinx_version"),
        "findings": findings(solved["stopped"], cmp["rows"]), "missing": missing_values(cmp["rows"])})
    on_root(comm, "writing comparison.json", write_json, out / "comparison.json", cmp)
    on_root(comm, "writing comparison.md", write_text, out / "comparison.md", comparison_markdown(cmp, info))
    return cmp


def _rung_label(mesh: dict[str, Any]) -> str:
    return f"P{mesh['degree']} r{mesh['refinement']}, suture {mesh['size_suture_mm']:g} mm"


def _estimates(solved: dict[str, Any], cones: tuple[int, ...]) -> dict[tuple[int, float], dict[str, Any]]:
    """USUM's estimated discretisation error by (cones, nominal force) where the case is on its rung."""
    out = {}
    for n in cones:
        rung = RUNGS.get(n)
        if rung is None or any(solved["rungs"][n].get(k.split(".", 1)[1]) != v for k, v in rung.values.items()):
            continue
        for f, err in rung.usum_error.items():
            out[(n, f)] = {"rel": err, "rung": rung.label, "estimate": rung.estimate}
    return out


def _band(cal: dict[str, Any]) -> tuple[str, float] | None:
    """(key, 95 % half-interval) whose USUM band the calibrated run propagates, or None.

    The band is |dUSUM/dp| times the parameter's 95 % half-interval, with dUSUM/dp by the direct method
    (one factorisation of the Jacobian per reported state). A geometric key's derivative is a
    remeshed finite difference, not available inside one ramp: no band then (the record says so).
    """
    if cal["status"] != "calibrated":
        return None
    if cal["sensitivity"] != DIRECT:
        cal["bands"] = "not propagated: the key is geometric (its sensitivity needs two remeshed solves per state)"
        return None
    cal["bands"] = "|dUSUM/dp| (direct method, at each reported state) times the parameter's 95 % half-interval"
    return cal["key"], (cal["ci95"][1] - cal["ci95"][0]) / 2


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
