"""The ledger's analysis: per force and quantity, every ladder's estimate, the reference, every rung's error.

Each quantity also gets a verdict: does it converge, and do the other ladders agree with the reference?

The reference value of a quantity is the extrapolated value of the ladder (degree, formulation)
whose Richardson correction is smallest; every rung's error is its distance to that reference.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from typing import Any

from suture_fem.studies.convergence.ladder import Rung, ladder_key
from suture_fem.studies.convergence.quantities import QUANTITIES, fmt_value, force_key
from suture_fem.studies.convergence.richardson import MIN_ORDER, SETTLED_REL, richardson, two_rung_error


def analyse(rungs: list[Rung], forces: Sequence[float]) -> dict[str, Any]:
    """Richardson estimates per ladder, the reference value and every rung's error, per force and quantity."""
    ladders: dict[str, list[Rung]] = {}
    for rung in rungs:
        if rung.status == "converged":
            ladders.setdefault(ladder_key(rung), []).append(rung)
    for seq in ladders.values():
        seq.sort(key=lambda r: r.refinement)
    analysis: dict[str, Any] = {}
    for force in forces:
        fk = force_key(force)
        per_q: dict[str, Any] = {}
        for q in QUANTITIES:
            estimates = {key: _estimate(seq, fk, q.path, q.tolerance) for key, seq in ladders.items()}
            reference = _reference(estimates)
            per_q[q.path] = {"label": q.label, "unit": q.unit, "estimates": estimates, "reference": reference,
                             "rungs": _errors(ladders, fk, q.path, reference),
                             "tolerance": q.tolerance or SETTLED_REL,
                             "verdict": _verdict(estimates, reference, q.unit, q.tolerance)}
        analysis[fk] = per_q
    return analysis


def _estimate(seq: list[Rung], fk: str, path: str, tolerance: float = 0.0) -> dict[str, Any]:
    """The Richardson estimate of one ladder (its rungs coarse to fine) and its changes per refinement.

    ``tolerance``: the quantity's own "settled" goal (:data:`~.quantities.STRESS_TOLERANCE`), 0 for none.
    """
    values = [r.values.get(fk, {}).get(path) for r in seq]
    # the consecutive run of refinements with a value, up to the finest
    pairs = [(r.refinement, v) for r, v in zip(seq, values) if v is not None]
    contiguous = _contiguous_tail(pairs)
    est = richardson([v for _, v in contiguous], settled_rel=SETTLED_REL, min_order=MIN_ORDER, tolerance=tolerance)
    return {
        "refinements": [k for k, _ in contiguous],
        "values": [v for _, v in contiguous],
        **asdict(est),
        "changes_rel": [abs(b - a) / abs(b) if b else None for (_, a), (_, b) in zip(contiguous, contiguous[1:])],
    }


def _reference(estimates: dict[str, Any]) -> dict[str, Any] | None:
    """The limit of the ladder with the smallest Richardson correction; None if no ladder has a limit."""
    good = {k: e for k, e in estimates.items() if e["verdict"] in ("converging", "settled")}
    if not good:
        return None
    best = min(good, key=lambda k: abs(good[k]["correction"]))
    return {"value": good[best]["limit"], "from": best, "correction": good[best]["correction"]}


def _errors(ladders: dict[str, list[Rung]], fk: str, path: str, reference: dict[str, Any] | None) -> dict[str, Any]:
    """Every rung's value, its error against the reference and its two-rung estimate (order 1 assumed)."""
    errors: dict[str, Any] = {}
    for seq in ladders.values():
        prev = None
        for r in seq:
            v = r.values.get(fk, {}).get(path)
            entry: dict[str, Any] = {"value": v}
            if v is not None and reference is not None and reference["value"]:
                entry["error_rel"] = abs(v - reference["value"]) / abs(reference["value"])
            if v is not None and prev is not None and prev[0] == r.refinement - 1:
                entry["two_rung_estimate_rel"] = two_rung_error(v, prev[1]) / abs(v) if v else None
            errors[r.name] = entry
            prev = (r.refinement, v) if v is not None else None
    return errors


def _contiguous_tail(pairs: list[tuple[int, float]]) -> list[tuple[int, float]]:
    tail: list[tuple[int, float]] = []
    for k, v in reversed(pairs):
        if tail and tail[0][0] != k + 1:
            break
        tail.insert(0, (k, v))
    return tail


def _agreement(estimates: dict[str, Any], reference: dict[str, Any]) -> tuple[str, bool]:
    """How far every other ladder's finest value lies from the reference, and whether all confirm it."""
    notes, confirmed = [], True
    for key, e in estimates.items():
        if key == reference["from"] or not e["values"]:
            continue
        off = abs(e["values"][-1] - reference["value"]) / abs(reference["value"])
        last = e["changes_rel"][-1] if e["changes_rel"] else None
        # another ladder confirms the reference when its finest value lies within twice the
        # reference's own uncertainty (its Richardson correction, at least SETTLED_REL)
        ok = off <= 2 * max(abs(reference["correction"] / reference["value"]), SETTLED_REL)
        confirmed = confirmed and ok
        own = f"; its last change {100 * last:.2g} %" if last is not None else ""
        notes.append(f"{key} finest {100 * off:.2g} % from it ({'confirms' if ok else 'does NOT confirm'}{own})")
    return (("; " + ", ".join(notes)) if notes else ""), confirmed


def _verdict(estimates: dict[str, Any], reference: dict[str, Any] | None, unit: str, tolerance: float = 0.0) -> str:
    """One sentence: does the quantity converge, and do the other ladders agree with the reference?"""
    kinds = {e["verdict"] for e in estimates.values()}
    finest = "; finest values " + ", ".join(f"{k}: {fmt_value(e['values'][-1], unit)}" for k, e in estimates.items()
                                             if e["values"]) if len(estimates) > 1 else ""
    agreement, confirmed = _agreement(estimates, reference) if reference is not None else ("", True)
    if "converging" in kinds or "settled" in kinds:
        orders = ", ".join(f"{k}: {e['order']:.2f}" for k, e in estimates.items() if e["verdict"] == "converging")
        head = (f"converges (observed order {orders})" if orders else _settled(estimates, tolerance))
        if not confirmed:
            head = (f"not settled: the {reference['from']} ladder suggests a limit ({head}) "
                    "that another degree contradicts")
        return head + agreement
    if "diverging" in kinds:
        return f"no limit in sight: the change per refinement does not shrink (observed order <= {MIN_ORDER:g}){finest}"
    if "oscillating" in kinds:
        return f"not monotone under refinement: no Richardson estimate{finest}"
    return f"too few rungs to tell{finest}"


def _settled(estimates: dict[str, Any], tolerance: float) -> str:
    """The verdict's head when every ladder with a limit has settled: below which change, and how."""
    if tolerance <= SETTLED_REL:
        return f"settled: changes below {100 * SETTLED_REL:g} % per refinement (no order measurable)"
    orders = ", ".join(f"{k}: {e['order']:.2f}" for k, e in estimates.items()
                       if e["verdict"] == "settled" and e["order"] is not None)
    how = (f"its Richardson correction within it too, observed order {orders}" if orders else
           "oscillating within it, the last change or the larger of the two taken as its uncertainty")
    return f"settled: the change between the two finest rungs is below {100 * tolerance:g} % ({how})"


def within(analysis: dict[str, Any], rungs: list[Rung], force: float, path: str, tol: float) -> dict[str, Any]:
    """Per ladder, the coarsest rung whose error is within ``tol`` (relative), with its cost."""
    per = analysis[force_key(force)][path]
    found: dict[str, Any] = {}
    for rung in sorted(rungs, key=lambda r: (r.degree, r.refinement)):
        err = per["rungs"].get(rung.name, {}).get("error_rel")
        key = ladder_key(rung)
        if err is not None and err <= tol and key not in found:
            found[key] = {"rung": rung.name, "refinement": rung.refinement, "error_rel": err,
                          "wall_time_s": rung.wall_time_s, "cpu_time_s": rung.cpu_time_s, "dofs": rung.dofs,
                          "peak_memory_mb": rung.peak_memory_mb}
    return found
