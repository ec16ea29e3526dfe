"""Solving the cone counts: one load ramp per cone count, the fields of every reported force kept.

A ramp that stops keeps its converged part: its results.json (rewritten after every converged step)
is read back, and the stop is recorded; the comparison then misses only the forces it did not reach.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

from suture_fem.pipeline import check
from suture_fem.scene import Scene
from suture_fem.studies.reproduce.paper import CONES
from suture_fem.support.errors import SolveStopped
from suture_fem.support.io import read_json
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")


def with_values(scene: Scene, values: dict[str, Any]) -> Scene:
    """The scene with dotted keys set to values, validated (the geometry's checks included)."""
    changed = scene.with_values(values)
    check(changed)
    return changed


def solve_cone_counts(scene: Scene, out: Path, comm: Any, fields: bool = True,
                      cones: tuple[int, ...] = CONES, on_state: Any = None) -> dict[str, Any]:
    """One load ramp per cone count of ``cones``; returns {"results": {n: results}, "grids": {(n, F): grid}, ...}.

    Grids (rank 0 only) are the solved states at every reported force, also written to
    ``out/fields/conesN_FN.vtu``. A ramp that stops keeps its converged part.
    """
    from suture_fem import plots
    from suture_fem.pipeline import run_scene

    results: dict[int, dict[str, Any]] = {}
    grids: dict[tuple[int, float], Any] = {}
    stopped: dict[int, str] = {}
    for n in cones:
        case = with_values(scene, {"geometry.cones": n, "output.fields": False})
        folder = out / f"cones_{n}"

        def on_report(force_n: float, outputs: Any, n: int = n) -> None:
            if on_state is not None:  # on_state(cones, force, outputs): e.g. the calibrated USUM's band
                on_state(n, force_n, outputs)
            if not fields:
                return
            grid = plots.field_grid(outputs)
            if comm.rank == 0:
                grids[(n, round(force_n, 6))] = grid
            on_root(comm, "writing a field file", lambda: grid is None or plots.save_grid(
                grid, out / "fields" / f"cones{n}_{force_n:g}N.vtu"))

        t0 = time.perf_counter()
        try:
            results[n] = run_scene(case, folder, comm, on_report=on_report)
        except SolveStopped as stop:
            log.error("%d cone(s): %s", n, stop)
            stopped[n] = str(stop)
            results[n] = comm.bcast(read_json(folder / "results.json") if comm.rank == 0 else None, root=0)
        log.info("%d cone(s): solved to %.3g N in %.0f s", n, results[n].get("force_reached_n", 0.0),
                 time.perf_counter() - t0)
    return {"results": results, "grids": grids, "stopped": stopped}
