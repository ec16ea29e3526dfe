"""The study's entry: calibrate one parameter on one value, solve every cone count, compare, draw, write."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.reproduce.calibration import DEFAULT, calibrate, not_calibrated, parse_key
from suture_fem.studies.reproduce.compare import comparison, ours
from suture_fem.studies.reproduce.figures import figures
from suture_fem.studies.reproduce.paper import CONES, SCENE, TARGET
from suture_fem.studies.reproduce.report import comparison_markdown
from suture_fem.studies.reproduce.solve import solve_cone_counts, with_values
from suture_fem.studies.reproduce.stress import stress_comparison
from suture_fem.support.io import write_json, write_text
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def reproduce(scene: Scene, out: Path, comm: Any, calibrate_key: str = DEFAULT, pictures: bool = True,
              scene_name: str = SCENE, cones: tuple[int, ...] = CONES, max_evaluations: int = 20) -> dict[str, Any]:
    """Calibrate one key on one value, solve every cone count, compare, draw; returns comparison.json's content.

    ``calibrate_key``: ``KEY[=LOW:HIGH]`` fitted to USUM 4.0 mm at 4 cones, 1 N (then the scene is also
    solved as it is, for the uncalibrated column, under ``out/uncalibrated``), or ``none``. With
    ``cones`` only a subset of the cone counts is solved: the values of the others are then missing.
    """
    t_start = time.perf_counter()
    key = parse_key(calibrate_key, scene)
    cal = not_calibrated(scene) if key is None else calibrate(scene, comm, key, out / "calibration", max_evaluations)
    uncalibrated, bands = None, {}
    if cal["status"] == "calibrated":
        uncalibrated = solve_cone_counts(scene, out / "uncalibrated", comm, fields=False, cones=cones)["results"]
        scene = with_values(scene, {key.key: cal["value"]})
    solved = solve_cone_counts(scene, out, comm, fields=pictures, cones=cones,
                               on_state=_band_hook(cal, bands) if cal["status"] == "calibrated" else None)
    results = solved["results"]
    cal["usum_mm_in_this_run"] = ours(results, TARGET.cones, TARGET.force_n, "usum_mm")[0]
    cmp = comparison(results, cal, scene, uncalibrated=uncalibrated, bands=bands)
    # issue 17: the converging measures, as solved and uncalibrated, with their error bars
    cmp["stress"] = stress_comparison(results, uncalibrated=uncalibrated) if {2, 4} <= set(results) else None
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


def _band_hook(cal: dict[str, Any], bands: dict[tuple[int, float], float]) -> Any:
    """on_state(cones, force, outputs): USUM's linearised 95 % band at each reported state of the calibrated run.

    The band is |dUSUM/dp| times the parameter's 95 % half-interval, with dUSUM/dp by the direct method
    (one factorisation of the Jacobian per reported state). A geometric key's derivative is a
    remeshed finite difference, not available inside one ramp: no band then (the record says so).
    """
    from suture_fem.studies.calibrate.keys import DIRECT
    from suture_fem.studies.calibrate.sensitivity import Sensitivity

    if cal["sensitivity"] != DIRECT:
        cal["bands"] = "not propagated: the key is geometric (its sensitivity needs two remeshed solves per state)"
        return None
    cal["bands"] = "|dUSUM/dp| (direct method, at each reported state) times the parameter's 95 % half-interval"
    half = (cal["ci95"][1] - cal["ci95"][0]) / 2
    made: dict[int, Any] = {}

    def on_state(cones: int, force_n: float, outputs: Any) -> None:
        if cones not in made:
            made.clear()
            made[cones] = Sensitivity(outputs.physics)
        _, d = made[cones].at_state("usum_mm", [cal["key"]])
        bands[(cones, round(force_n, 6))] = abs(float(d[0])) * half

    return on_state


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
