"""The pipeline of one scene: scene -> geometry -> mesh -> physics -> load ramp -> outputs -> results.json.

:func:`load_scene` reads and validates a scene completely (keys, types, ranges, then the checks that
need the geometry and the effects), before any meshing; :func:`run_scene` solves it with a
:class:`~suture_fem.model.Model` (which owns the mesh, the physics, the outputs and the load ramp).

``results.json`` is rewritten (atomically) after every converged load step, so a run that stops
later keeps everything it had computed; its ``status`` says "running", "converged", "stopped" (a
diagnosis), "interrupted" (SIGINT, SIGTERM) or "failed" (e.g. a full disk; ``error`` says why), and
``process`` names the process that wrote it. The outputs of an earlier run in the same folder are
removed first, so no stale file stays beside new results.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from suture_fem.model import Model, check
from suture_fem.outputs.results import Results
from suture_fem.outputs.steps import OUTPUT_FILES, OnReport, output_folder
from suture_fem.scene import Scene, parse_scene
from suture_fem.support.errors import SceneError

log = logging.getLogger("suture_fem")

__all__ = ["OUTPUT_FILES", "OnReport", "check", "check_ranks", "load_scene", "run_scene", "scene_model", "with_values"]


def load_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> Scene:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; fully validated.

    Raises SceneError (one line naming the key and its allowed range) before anything is meshed.
    """
    scene = parse_scene(source, overrides)
    check(scene)
    return scene


def with_values(scene: Scene, values: dict[str, Any]) -> Scene:
    """The scene with dotted keys set, validated as :func:`load_scene` validates (the geometry's checks too)."""
    changed = scene.with_values(values)
    check(changed)
    return changed


def scene_model(scene: Scene, out_dir: str | Path | None, comm: Any) -> Model:
    """The :class:`Model` of a validated scene, its output folder prepared first (collective).

    An unusable folder stops every rank before meshing. ``model.solve(out_dir)`` then writes
    results.json there; ``model.reports()`` sets the state of each reported force after the solve.
    """
    check_ranks(scene, comm)
    output_folder(out_dir, comm)
    return Model(scene, comm, checked=True)


def check_ranks(scene: Scene, comm: Any) -> None:
    """SceneError before any folder or mesh when the scene's linear solver cannot run on ``comm``'s ranks.

    PETSc's own LU factorises on one process only: under MPI it fails inside PETSc (pages of errors).
    """
    factor = "pc_factor_mat_solver_type"
    chosen = {"solver.linear_solver": scene.solver.linear_solver,
              f"solver.petsc_options.{factor}": scene.solver.petsc_options.get(factor)}
    for key, value in chosen.items():
        if comm.size > 1 and value == "petsc":
            raise SceneError(f'scene key {key} = "petsc": PETSc\'s own LU runs on one process, not on {comm.size} '
                             'MPI ranks; use "mumps" or "superlu_dist" under mpirun')


def run_scene(scene: Scene, out_dir: str | Path | None, comm: Any, on_report: OnReport | None = None) -> Results:
    """Solve a validated scene; write ``out_dir/results.json`` (rank 0) and return its :class:`Results`.

    ``scene_model(scene, out_dir, comm).solve(out_dir, on_report)`` (:class:`suture_fem.model.Model`).
    ``on_report(force_n, outputs)`` (deprecated), if given, is called (on every rank) at each reported
    force with the Outputs of the solved state; a caller that needs those states uses
    :func:`scene_model` and ``model.reports()`` instead. The Results read like results.json's dict
    (``results["usum_mm"]``); ``results.to_dict()`` is that dict.
    Raises SolveStopped after writing the converged part when the ramp cannot be completed.
    """
    return scene_model(scene, out_dir, comm).solve(out_dir, on_report)
