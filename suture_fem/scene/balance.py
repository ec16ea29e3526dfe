"""What "converged" means, and how long a ramp must take: the cross-key rules checked before any meshing.

A state counts as converged only when it balances the force applied then to :data:`BALANCE_TOL`
(the residual left at the free degrees of freedom, N, over that force), or to the residual's round-off
floor where that is higher (a moved end that takes almost no force; results.json's residual_floor_n);
the stepping lets that decide (:mod:`suture_fem.solve.stepping`). So the tolerances a scene may set
are those that can meet it: a relative tolerance of at most BALANCE_TOL (:mod:`suture_fem.scene.schema`),
an absolute one (N) of at most BALANCE_TOL times the pull (:func:`check_tolerances`; the solves also
stop at no more than BALANCE_TOL times the force applied at each step). The number of steps a ramp
needs is known before meshing, as the mesh's size is (:mod:`suture_fem.geometry.estimate`):
:func:`check_steps` refuses a scene that cannot finish. Pure Python on the validated scene mapping.
"""

from __future__ import annotations

from typing import Any

from suture_fem.support.errors import SceneError

#: The force balance a state must meet to count as converged: the residual left at the free degrees of
#: freedom (N) at most this fraction of the force applied then. The Newton solves stop at the smaller
#: of ``solver.atol`` and this fraction of the force; the paper scene ends its steps near 2e-10 of the
#: force (the residual's round-off floor, 7e-10 N at 4 N).
BALANCE_TOL = 1e-6
#: Smallest pull (N) a scene may apply or report: far below it the rounding of the reaction (6e-18 N on
#: the paper scene pulled with 1e-300 N) is no longer small beside BALANCE_TOL of the force.
MIN_FORCE_N = 1e-6
#: Smallest load step, as a fraction of the ramp: the stepping lands on report points to 1e-12 of the
#: ramp, so a step must be well above that to make progress (1e-300 divided by zero in the predictor).
MIN_STEP = 1e-9
#: Most load or time steps a scene's path may need at the least: a step costs at least about a second on
#: the paper scene's mesh (one to a few Newton iterations), so 20,000 steps are six hours or more.
MAX_STEPS = 20_000


def check_tolerances(scene: dict[str, Any]) -> None:
    """solver.atol (and a petsc_options.snes_atol) at most BALANCE_TOL times the pull (force control)."""
    loading, solver = scene["loading"], scene["solver"]
    if loading["control"] != "force":
        return  # the force is the end's reaction, known only in the solve: the stepping's check stands alone
    force = loading["force_n"] * loading["force_scale"]
    if force < MIN_FORCE_N:
        raise SceneError(f"scene keys loading.force_n x loading.force_scale = {force:.3g} N: the pull must be at "
                         f"least {MIN_FORCE_N:g} N, or its balance cannot be told from rounding")
    limit = BALANCE_TOL * force
    for key, value in (("solver.atol", solver["atol"]),
                       ("solver.petsc_options.snes_atol", solver["petsc_options"].get("snes_atol"))):
        if value is not None and value > limit:
            raise SceneError(f"scene key {key} = {value:g} N: a converged state must balance the pull to "
                             f"{BALANCE_TOL:g} of it, so {key} must be <= {limit:.3g} N here ({BALANCE_TOL:g} x "
                             f"{force:g} N)")


def least_steps(scene: dict[str, Any]) -> tuple[float, str]:
    """The fewest steps the scene's path can take, and the keys that set it (in words)."""
    loading, solver, effects = scene["loading"], scene["solver"], scene["effects"]
    if effects["inertia"]:
        duration = loading["ramp_s"] + loading["hold_s"]
        return duration / effects["time_step_s"], (
            f"(loading.ramp_s + loading.hold_s) / effects.time_step_s = {duration:g} s / {effects['time_step_s']:g} s")
    return 1.0 / solver["max_step"], f"1 / solver.max_step = 1 / {solver['max_step']:g}"


def check_steps(scene: dict[str, Any]) -> None:
    """SceneError (one line) when the path needs more than MAX_STEPS steps at the least."""
    steps, how = least_steps(scene)
    if steps > MAX_STEPS:
        raise SceneError(f"the load path needs at least {steps:.3g} steps ({how}); at most {MAX_STEPS:,} are "
                         f"allowed (about a second each on the paper scene's mesh: {_duration(steps)})")


def _duration(seconds: float) -> str:
    for unit, size in (("years", 365 * 86400.0), ("days", 86400.0), ("hours", 3600.0)):
        if seconds >= 2 * size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"
