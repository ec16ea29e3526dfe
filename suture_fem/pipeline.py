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

log = logging.getLogger("suture_fem")

__all__ = ["OUTPUT_FILES", "OnReport", "check", "load_scene", "run_scene"]


def load_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> Scene:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; fully validated.

    Raises SceneError (one line naming the key and its allowed range) before anything is meshed.
    """
    scene = parse_scene(source, overrides)
    check(scene)
    return scene


def run_scene(scene: Scene, out_dir: str | Path | None, comm: Any, on_report: OnReport | None = None) -> Results:
    """Solve a validated scene; write ``out_dir/results.json`` (rank 0) and return its :class:`Results`.

    ``Model(scene, comm).solve(out_dir, on_report)`` (:class:`suture_fem.model.Model`), with the output
    folder prepared before meshing. ``on_report(force_n, outputs)``, if given, is called (on every
    rank) at each reported force with the Outputs of the solved state, for pictures:
    ``outputs.physics.u`` is the displacement and ``outputs.cell_maxima()`` the von Mises stress and
    equivalent strain per cell; ``outputs.newton`` is the Newton solver that just converged (None in
    the report of a stopped ramp's last state). A Model gives the same state without the hook.
    The Results read like results.json's dict (``results["usum_mm"]``); ``results.to_dict()`` is that dict.
    Raises SolveStopped after writing the converged part when the ramp cannot be completed.
    """
    output_folder(out_dir, comm)  # an unusable folder stops every rank before meshing
    return Model(scene, comm, checked=True).solve(out_dir, on_report)
