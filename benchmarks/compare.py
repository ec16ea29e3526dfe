"""Two results.json forms compared value by value, for the benchmarks that put an answer beside another
(many_answers, warm_answers): the largest relative difference, where, and how many values exceed 1e-10."""

from __future__ import annotations

from typing import Any

#: What two runs of the same code may write differently.
NOT_COMPARED = {"wall_time_s", "timings_s", "process"}
#: With ``--start previous`` also not compared: what a warm start changes by design, the ramp's points and
#: counts (it steps straight to the reported forces) and the residual each state was left with (converged by
#: the same tests on both sides; two residuals below the tolerance have no relative difference to speak of).
WARM_NOT_COMPARED = {"newton_iterations", "load_steps", "cutbacks", "force_displacement", "inertia_shifts",
                     "domain_rejections", "line_search_switches", "linear_solver", "linear_solver_fallbacks",
                     "residual_floor_n", "solves_at_residual_floor", "free_residual_norm_n", "force_balance_rel"}


def differences(a: Any, b: Any, skip: set[str], path: str = "") -> list[tuple[float, str]]:
    """Every compared value's relative difference and where (inf where two values differ otherwise)."""
    if isinstance(a, dict):
        if set(a) - skip != set(b) - skip:
            return [(float("inf"), f"{path}: keys")]
        return [d for k in sorted(set(a) - skip) for d in differences(a[k], b[k], skip, f"{path}.{k}")]
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return [(float("inf"), f"{path}: length")]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, skip, f"{path}[{i}]")]
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        return [((abs(a - b) / max(abs(a), abs(b), 1e-300)) if a != b else 0.0, path)]
    return [(0.0 if a == b else float("inf"), path)]


def compare(a: Any, b: Any, skip: set[str]) -> dict[str, Any]:
    """The largest relative difference of two results.json forms, where, how many values were compared and how many
    exceed 1e-10."""
    found = differences(a, b, skip)
    largest = max(found, default=(0.0, ""))
    return {"difference": largest[0], "difference_at": largest[1], "compared": len(found),
            "above_1e-10": sum(d > 1e-10 for d, _ in found)}
