"""Solving the cone counts: one load ramp per cone count, the fields of every reported force kept.

Each cone count is solved on its mesh rung (:mod:`suture_fem.studies.reproduce.rungs`), in this
process one after the other (``jobs`` 1, or under mpirun) or in ``jobs`` processes at once, this one
and ``jobs`` - 1 children (:mod:`suture_fem.studies.reproduce.jobs`, each a serial ``suture-fem
reproduce-ramp``); both run
:func:`solve_case`, so the results are the same. A ramp that stops keeps its converged part: its
results.json (rewritten after every converged step) is read back, and the stop is recorded; the
comparison then misses only the forces it did not reach.
"""

from __future__ import annotations

import logging
import resource
import time
from pathlib import Path
from typing import Any

from suture_fem.pipeline import with_values
from suture_fem.scene import Scene
from suture_fem.studies.calibrate.sensitivity import Sensitivity
from suture_fem.studies.paper import CONES
from suture_fem.studies.reproduce.rungs import RUNGS, rung_values
from suture_fem.support.errors import SolveStopped
from suture_fem.support.io import read_json
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def case_scene(scene: Scene, cones: int, fixed: frozenset[str] | None = frozenset()) -> Scene:
    """The scene of one cone count on its mesh rung (the keys in ``fixed`` kept; ``fixed`` None: no rung)."""
    rung = rung_values(RUNGS.get(cones), fixed) if fixed is not None else {}
    return with_values(scene, {"geometry.cones": cones, "output.fields": False, **rung})


def field_path(fields_dir: Path, cones: int, force_n: float) -> Path:
    """Where the state of ``cones`` at ``force_n`` is written (pyvista, ParaView)."""
    return fields_dir / f"cones{cones}_{force_n:g}N.vtu"


def solve_case(scene: Scene, folder: Path, comm: Any, fields_dir: Path | None = None,
               band: tuple[str, float] | None = None) -> dict[str, Any]:
    """One cone count's ramp into ``folder``; returns {"results", "stopped", "bands", "grids"}.

    ``fields_dir``: the state at every reported force is also written there (:func:`field_path`) and
    kept in "grids" (rank 0). ``band`` (key, 95 % half-interval of the key): USUM's linearised band at
    every reported force, |dUSUM/dkey| (direct method, with the Jacobian assembled and factorised at
    the model's state of that force) times the half-interval, in "bands" {force: half-width (mm)}.
    """
    from suture_fem.pipeline import scene_model

    model = scene_model(scene, folder, comm)
    stopped = None
    try:
        results = model.solve(folder).to_dict()
    except SolveStopped as stop:
        log.warning("%d cone(s): %s", scene.geometry.cones, stop)  # a finding; missing values decide the exit
        stopped = str(stop)
        results = comm.bcast(read_json(folder / "results.json") if comm.rank == 0 else None, root=0)
    bands, grids = _at_reports(model, comm, fields_dir, band)
    return {"results": results, "stopped": stopped, "bands": bands, "grids": grids}


def _at_reports(model: Any, comm: Any, fields_dir: Path | None,
                band: tuple[str, float] | None) -> tuple[dict[float, float], dict[float, Any]]:
    """USUM's band and the field grid (written to ``fields_dir``) at every reported force of the model's solve."""
    from suture_fem import plots

    n = model.scene.geometry.cones
    grids: dict[float, Any] = {}
    bands: dict[float, float] = {}
    sensitivity = None
    for report in model.reports():
        force_n = report.force_n
        if band is not None:
            sensitivity = sensitivity or Sensitivity(model.physics)
            slope = sensitivity.at_state("usum_mm", [band[0]])[1][0]  # A assembled and factorised at the state
            bands[round(force_n, 6)] = abs(float(slope)) * band[1]
        if fields_dir is None:
            continue
        grid = plots.field_grid(model.outputs)
        if comm.rank == 0:
            grids[round(force_n, 6)] = grid
        on_root(comm, "writing a field file", _save, grid, field_path(fields_dir, n, force_n))
    return bands, grids


def _save(grid: Any, path: Path) -> None:
    """Write a field grid (pyvista), if this rank has it."""
    from suture_fem import plots

    if grid is not None:
        plots.save_grid(grid, path)


def solve_cone_counts(scene: Scene, out: Path, comm: Any, fields: bool = True, cones: tuple[int, ...] = CONES,
                      band: tuple[str, float] | None = None, fixed: frozenset[str] | None = frozenset(),
                      jobs: int = 1) -> dict[str, Any]:
    """One load ramp per cone count of ``cones``, each on its rung; returns the results and what they cost.

    {"results": {n: results}, "grids": {(n, F): grid}, "stopped": {n: why}, "bands": {(n, F): mm},
    "cpu_time_s": CPU seconds of the ramps (summed over ranks, or over the child processes), "jobs"}.
    Grids (rank 0 only) are the solved states at every reported force, also written to
    ``out/fields/conesN_FN.vtu``. ``fixed``: the mesh keys the user set (kept), None for no rungs at all.
    """
    cases = {n: case_scene(scene, n, fixed) for n in cones}
    fields_dir = out / "fields" if fields else None
    t0 = time.perf_counter()
    if jobs > 1 and comm.size == 1:
        from suture_fem.studies.reproduce.jobs import solve_in_processes

        costs = {n: getattr(RUNGS.get(n), "cpu_s", 0.0) or float(n) for n in cases}
        solved, cpu = solve_in_processes(cases, out, comm, fields_dir, band, jobs, costs)
    else:
        cpu0 = cpu_self()
        solved = {}
        for n, case in cases.items():
            t1 = time.perf_counter()
            solved[n] = solve_case(case, out / f"cones_{n}", comm, fields_dir, band)
            log.info("%d cone(s): solved to %.3g N in %.1f s", n, solved[n]["results"].get("force_reached_n", 0.0),
                     time.perf_counter() - t1)
        cpu = comm.allreduce(cpu_self() - cpu0)
    log.info("cone counts %s: %.1f s CPU, %.1f s wall (%d job(s))", ",".join(map(str, cones)), cpu,
             time.perf_counter() - t0, jobs)
    return {
        "results": {n: s["results"] for n, s in solved.items()},
        "grids": {(n, f): g for n, s in solved.items() for f, g in s["grids"].items()},
        "stopped": {n: s["stopped"] for n, s in solved.items() if s["stopped"]},
        "bands": {(n, f): b for n, s in solved.items() for f, b in s["bands"].items()},
        "cpu_time_s": cpu,
        "jobs": min(jobs, len(cases)) if comm.size == 1 else 1,  # at most one process per cone count
        "rungs": {n: case.as_dict()["mesh"] for n, case in cases.items()},
    }


def cpu_self(children: bool = False) -> float:
    """CPU seconds (user + system) of this process so far (``children``: and of its ended child processes)."""
    kinds = (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN) if children else (resource.RUSAGE_SELF,)
    return sum(u.ru_utime + u.ru_stime for u in map(resource.getrusage, kinds))
