"""The pipeline of one scene: scene -> geometry -> mesh -> physics -> load ramp -> outputs -> results.json.

:func:`load_scene` reads and validates a scene completely (keys, types, ranges, then the checks that
need the geometry and the effects), before any meshing; :func:`run_scene` solves it.

``results.json`` is rewritten (atomically) after every converged load step, so a run that stops
later keeps everything it had computed; its ``status`` says "running", "converged" or "stopped".
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from suture_fem import __version__
from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.section import Geometry
from suture_fem.outputs.evaluate import FieldWriter, Outputs
from suture_fem.physics.effects import check_scene
from suture_fem.physics.problem import build_physics
from suture_fem.scene import Scene, parse_scene
from suture_fem.solve.newton import Timings, ramp
from suture_fem.support import compat
from suture_fem.support.errors import SolveStopped
from suture_fem.support.io import write_json
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def load_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> Scene:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; fully validated.

    Raises SceneError (one line naming the key and its allowed range) before anything is meshed.
    """
    scene = parse_scene(source, overrides)
    check(scene)
    return scene


def check(scene: Scene) -> None:
    """The cross-key checks that need the geometry (cones that fit) and the effects (SceneError)."""
    Geometry.from_section(scene.geometry)
    check_scene(scene)


def run_scene(
    scene: Scene,
    out_dir: str | Path | None,
    comm: Any,
    on_report: Callable[[float, Any], None] | None = None,
) -> dict[str, Any]:
    """Solve a validated scene; write ``out_dir/results.json`` (rank 0) and return the results.

    ``on_report(force_n, outputs)``, if given, is called (on every rank) at each reported force with
    the Outputs of the solved state, for pictures: ``outputs.physics.u`` is the displacement and
    ``outputs.cell_maxima()`` the von Mises stress and equivalent strain per cell.
    Raises SolveStopped after writing the converged part when the ramp cannot be completed.
    """
    t_start = time.perf_counter()
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:  # an unusable output folder stops every rank now, not after the solve
        on_root(comm, f"creating the output folder {out}", out.mkdir, parents=True, exist_ok=True)
    timings = Timings()
    t0 = time.perf_counter()
    tagged = meshmod.create_mesh(comm, scene.geometry, scene.mesh)
    meshing = time.perf_counter() - t0
    t0 = time.perf_counter()
    physics = build_physics(tagged, scene)
    outputs = Outputs(physics, scene.output, quantities=physics.effects.quantities)
    timings.form_compilation += time.perf_counter() - t0
    results: dict[str, Any] = {
        "status": "running",
        "suture_fem_version": __version__,
        "dolfinx_version": compat.DOLFINX_VERSION,
        "mpi_ranks": comm.size,
        "dofs": physics.num_dofs(),
        "unknowns": physics.num_unknowns(),
        **meshmod.describe(tagged),
        "applied_force_n": scene.loading.force_n,
        "force_displacement": [[0.0, 0.0]],
        "at_forces": [],
        "effects": physics.effects_record(),
        "scene": scene.as_dict(),
    }
    writer = FieldWriter(physics, outputs, str(out / "fields.xdmf")) if out and scene.output.fields else None

    def save() -> None:
        results["wall_time_s"] = time.perf_counter() - t_start
        results["timings_s"] = {"meshing": round(meshing, 4), **timings.as_dict()}
        if out is not None:
            on_root(comm, f"writing {out / 'results.json'}", write_json, out / "results.json", results)

    def on_converged(force_n: float, report: bool, time_s: float | None = None) -> None:
        results["force_displacement"].append([force_n, outputs.thread_end_displacement_mm()])
        if time_s is not None:  # with inertia: [t (s), F (N), thread end displacement (mm)]
            results.setdefault("time_history", []).append([time_s, *results["force_displacement"][-1]])
        if report:
            record = outputs.evaluate()
            results["at_forces"].append(record)
            results.update({k: v for k, v in record.items() if k != "force_n"})
            results["force_reached_n"] = force_n
            if writer is not None:
                writer.write(force_n)
            if on_report is not None:
                on_report(force_n, outputs)
        save()

    def bookkeeping(history: Any) -> None:
        results.update(
            {
                "load_steps": len(history.steps),
                "newton_iterations": history.newton_iterations,
                "cutbacks": history.cutbacks,
                "linear_solver": history.linear_solver,
                "linear_solver_fallbacks": history.fallbacks,
                "domain_rejections": history.domain_rejections,
                "line_search_switches": history.line_search_switches,
                "residual_floor_n": history.residual_floor_n,
                "solves_at_residual_floor": history.floor_above_atol,
            }
        )

    try:
        history = ramp(physics, scene, on_converged, timings)
    except SolveStopped as stop:
        if stop.history is not None:
            bookkeeping(stop.history)
        results["status"] = "stopped"
        results["diagnosis"] = {
            "cause": stop.cause,
            "load_reached_n": stop.load_reached,
            "attempted_n": stop.attempted,
            "detail": stop.detail,
        }
        if stop.load_reached > 0 and (not results["at_forces"] or results["at_forces"][-1]["force_n"] < stop.load_reached):
            record = outputs.evaluate()  # the last converged state, so its fields are not lost
            results["at_forces"].append(record)
            results.update({k: v for k, v in record.items() if k != "force_n"})
            results["force_reached_n"] = stop.load_reached
            if writer is not None:
                writer.write(stop.load_reached)
            if on_report is not None:
                on_report(stop.load_reached, outputs)
        save()
        raise
    finally:
        if writer is not None:
            writer.close()
    bookkeeping(history)
    results["status"] = "converged"
    save()
    return results
