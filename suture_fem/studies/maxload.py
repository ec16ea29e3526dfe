"""``suture-fem maxload SCENE``: the largest force a scene carries before a physical limit, bracketed.

The scene is ramped toward ``--up-to`` newtons with the adaptive load stepping of
:mod:`suture_fem.solve`, its smallest step set so that the last converged force and the first
failed one are less than ``--tol`` newtons apart (a failed step is halved until it is shorter than
2 * solver.min_step * F, so solver.min_step = tol / (2 F)). The run stops where no admissible
equilibrium is found any more: the Gent limit reached (cause ``gent_limit``), an element about to
invert (``inverted_element``), or Newton failing for no physical reason (``newton_divergence``,
``linear_solver``, reported as numerical, not as a limit of the tissue). When the whole ramp
converges, the answer is a lower bound only ("carries at least --up-to").

Writes DIR/maxload.json (the bracket, its cause, the tolerance) next to DIR/results.json (the ramp,
every converged step kept). Exit code 0 when a bracket or a lower bound was found, 3 when the ramp
stopped for a numerical reason. A physical stop whose bracket is wider than ``--tol`` (the cutbacks
gave up first) is not "bracketed": the record and the message give the width reached.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.scene.balance import MIN_STEP
from suture_fem.support.errors import SceneError, SolveStopped, StopCause
from suture_fem.support.io import write_json

#: The stops that are a limit of the tissue, not of the numerics: they bracket the largest force.
PHYSICAL = (StopCause.GENT_LIMIT, StopCause.INVERTED_ELEMENT)


def search_scene(scene: Scene, up_to_n: float, tol_n: float) -> Scene:
    """The scene set up for the search: ramp to up_to_n with a minimum step that brackets to tol_n."""
    if not 0 < tol_n < up_to_n:
        raise SceneError(f"maxload: --tol = {tol_n:g} N must be > 0 and < --up-to = {up_to_n:g} N")
    if tol_n < 2.0 * MIN_STEP * up_to_n:  # the smallest step solver.min_step may take, in newtons
        raise SceneError(f"maxload: --tol = {tol_n:g} N: the load steps resolve at most {MIN_STEP:g} of --up-to = "
                         f"{up_to_n:g} N, so --tol must be >= {2.0 * MIN_STEP * up_to_n:.3g} N")
    return scene.with_values({
        "loading.force_n": up_to_n,
        "loading.report_forces_n": [],
        "solver.min_step": min(tol_n / (2.0 * up_to_n), scene.solver.initial_step),
    })


def max_load(scene: Scene, comm: Any, up_to_n: float, tol_n: float, out: Path | None) -> dict[str, Any]:
    """Ramp toward up_to_n and return the bracket record (also written to out/maxload.json)."""
    from suture_fem.pipeline import run_scene
    from suture_fem.support.parallel import on_root

    searched = search_scene(scene, up_to_n, tol_n)
    record: dict[str, Any] = {"up_to_n": up_to_n, "tolerance_n": tol_n, "min_step": searched.solver.min_step}
    try:
        results = run_scene(searched, out, comm)
        record.update({
            "bracketed": False, "cause": None, "max_force_n": None, "carries_at_least_n": up_to_n,
            "note": f"the whole ramp to {up_to_n:g} N converged: no limit below it (raise --up-to)",
            "wall_time_s": results["wall_time_s"],
        })
    except SolveStopped as stop:
        physical = stop.cause in PHYSICAL
        width = stop.attempted - stop.load_reached
        record.update({
            "bracketed": physical and width <= tol_n,
            "tolerance_met": width <= tol_n,
            "cause": stop.cause,
            "limit": "physical" if physical else "numerical",
            "max_force_n": stop.load_reached,
            "bracket_n": [stop.load_reached, stop.attempted],
            "width_n": width,
            "detail": stop.detail,
        })
        if width > tol_n:
            record["note"] = (f"the bracket is {width:.3g} N wide, not within --tol = {tol_n:g} N: the step was cut "
                              "until it failed for good before it was that short (the detail says why)")
    if out is not None:
        on_root(comm, f"writing {out / 'maxload.json'}", write_json, out / "maxload.json", record)
    return record
