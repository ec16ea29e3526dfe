"""The comparison: every paper value side by side with ours, the relative errors, the paper's trends.

The paper's SEQV values (0.2-2.5 MPa) are tissue stresses: the overall maximum of our model is the
axial stress of the thread (about 20 MPa per newton), so SEQV is compared with the tissue maximum
``regions.tissue.seqv_pa``; the maximum outside ``output.rim_exclusion_mm`` of every cone corner
(not singular, unlike the peak at a sharp rim, though still mesh-dependent at the meshes used here)
is reported next to it, and likewise for EPTOEQV.
"""

from __future__ import annotations

from typing import Any

from suture_fem.geometry.regions import WHOLE_TISSUE
from suture_fem.scene import Scene
from suture_fem.studies.paper import CONES, FORCES_N, PAPER, TARGET


def _record(results: dict[str, Any] | None, force_n: float) -> dict[str, Any] | None:
    """The record at the nominal force ``force_n``.

    results.json's force_n is the applied force: the nominal one times ``loading.force_scale``.
    """
    scale = float(((results or {}).get("scene") or {}).get("loading", {}).get("force_scale", 1.0))
    for rec in (results or {}).get("at_forces", []):
        if abs(rec["force_n"] - force_n * scale) <= 1e-6 * force_n * scale:
            return rec
    return None


def ours(results: dict[int, dict[str, Any]], cones: int, force_n: float, quantity: str) -> tuple[Any, Any]:
    """(maximum, measure outside the rims) of one quantity, as compared with the paper; None where not solved.

    USUM: the maximum of |u| over the model (no second measure: it converges). SEQV and EPTOEQV: the
    tissue maximum, and the tissue maximum outside ``output.rim_exclusion_mm`` of every cone corner.
    """
    rec = _record(results.get(cones), force_n)
    if rec is None:
        return None, None
    if quantity == "usum_mm":
        return rec["usum_mm"], None
    tissue = rec["regions"][WHOLE_TISSUE]
    alt = "seqv_outside_rim_pa" if quantity == "seqv_pa" else "eptoeqv_outside_rim"
    return tissue[quantity], tissue.get(alt)


def rel(ours_value: Any, paper: float) -> Any:
    """(ours - paper) / paper; None where ours is missing."""
    return None if ours_value is None else (ours_value - paper) / paper


def _role(p: Any, status: str | None) -> str:
    if p.typo:
        return "not used: typo"
    if p is TARGET and status != "not calibrated":
        return "calibrated" if status == "calibrated" else "calibration target (not reached)"
    return "predicted"


def comparison(results: dict[int, dict[str, Any]], calibration: dict[str, Any], scene: Scene,
               uncalibrated: dict[int, dict[str, Any]] | None = None,
               bands: dict[tuple[int, float], float] | None = None,
               errors: dict[tuple[int, float], dict[str, Any]] | None = None) -> dict[str, Any]:
    """Every paper value side by side with ours, the trends, and the largest prediction error.

    ``results`` are the solved (calibrated, when a calibration reached its target) cone counts;
    ``uncalibrated`` the scene as it was, when it differs (then each row also has ``uncalibrated``
    and its error); ``bands`` the 95 % half-widths of the calibrated USUM by (cones, force);
    ``errors`` USUM's estimated relative discretisation error on its mesh rung by (cones, nominal
    force): {"rel", "rung", "estimate"} (each USUM row then has ``usum_discretisation_error``).
    """
    rows = []
    for p in PAPER:
        value, alt = ours(results, p.cones, p.force_n, p.quantity)
        before = ours(uncalibrated, p.cones, p.force_n, p.quantity)[0] if uncalibrated is not None else value
        band = (bands or {}).get((p.cones, round(p.force_n, 6))) if p.quantity == "usum_mm" else None
        est = (errors or {}).get((p.cones, round(p.force_n, 6))) if p.quantity == "usum_mm" else None
        rows.append({
            "source": p.source, "cones": p.cones, "force_n": p.force_n, "quantity": p.quantity,
            "paper": p.value, "paper_printed": p.printed, "ours": value,
            "rel_error": None if p.typo else rel(value, p.value), "band95": band,
            "uncalibrated": before, "uncalibrated_rel_error": None if p.typo else rel(before, p.value),
            "ours_outside_rims": alt, "rel_error_outside_rims": None if p.typo else rel(alt, p.value),
            "role": _role(p, calibration.get("status")), "note": p.typo,
            "usum_discretisation_error": est,
        })
    usum_ref = ours(results, TARGET.cones, TARGET.force_n, "usum_mm")[0]
    shape = []
    for r in rows:
        if r["quantity"] == "usum_mm" and usum_ref is not None and r["ours"] is not None:
            paper_rel, ours_rel = r["paper"] / TARGET.value, r["ours"] / usum_ref
            shape.append({"source": r["source"], "cones": r["cones"], "force_n": r["force_n"], "paper": paper_rel,
                          "ours": ours_rel, "rel_error": rel(ours_rel, paper_rel)})
    predicted = [r for r in rows if r["role"] == "predicted" and r["rel_error"] is not None]
    worst = max(predicted, key=lambda r: abs(r["rel_error"]), default=None)
    worst_alt = max((r for r in predicted if r["rel_error_outside_rims"] is not None),
                    key=lambda r: abs(r["rel_error_outside_rims"]), default=None)
    usum_predicted = [r for r in predicted if r["quantity"] == "usum_mm"]
    return {
        "rows": rows,
        "largest_prediction_error": worst,
        "largest_usum_prediction_error": max(usum_predicted, key=lambda r: abs(r["rel_error"]), default=None),
        "largest_prediction_error_outside_rims": worst_alt,
        "usum_relative_to_target": shape,
        "trends": trends(results),
        "usum_discretisation_errors": [{"cones": n, "force_n": f, **e} for (n, f), e in sorted((errors or {}).items())],
        "calibration": calibration,
        "measures": {
            "usum_mm": "maximum of |u| over the displacement nodes of the whole model (mm)",
            "seqv_pa": "maximum von Mises stress over the tissue's quadrature points (Pa); the overall maximum "
                       "is the thread's axial stress, about 20 MPa per newton, not what the paper reports",
            "eptoeqv": "maximum equivalent Hencky strain over the tissue's quadrature points",
            "outside_rims": f"the same maximum over points farther than {scene.output.rim_exclusion_mm:g} mm "
                            "from every cone corner (the peak at a sharp rim is a singularity, this is not; both still "
                            "change with the mesh, see docs/reproduction.md)",
        },
    }


def series(results: dict[int, dict[str, Any]], quantity: str, cones: Any, forces: Any, alt: bool = False) -> list:
    """One quantity over cones x forces (cones varying slowest); ``alt``: the measure outside the rims."""
    return [ours(results, n, f, quantity)[1 if alt else 0] for n in cones for f in forces]


def _falls(values: list) -> bool | None:
    if any(v is None for v in values):
        return None
    return all(b < a for a, b in zip(values, values[1:]))


def _rises(values: list) -> bool | None:
    if any(v is None for v in values):
        return None
    return all(b > a for a, b in zip(values, values[1:]))


def trends(results: dict[int, dict[str, Any]]) -> list[dict[str, Any]]:
    """The paper's trends and whether our values show them (None where a value is missing).

    "Less than linearly with force" means USUM/F falls from 1 to 4 N (the secant stiffness grows).
    """
    out = []

    def add(name: str, paper: str, values: list, holds: bool | None, alt_values: list | None = None,
            alt_holds: bool | None = None) -> None:
        out.append({"trend": name, "paper": paper, "ours": values, "holds": holds,
                    "ours_outside_rims": alt_values, "holds_outside_rims": alt_holds})

    usum_cones = series(results, "usum_mm", CONES, [1.0])
    add("USUM falls with the number of cones (1 N, 1-4 cones)", "7.3 / 5.1 / 4.4 / 4.0 mm", usum_cones,
        _falls(usum_cones))
    for n in CONES:
        usum_f = series(results, "usum_mm", [n], FORCES_N)
        per_n = None if None in usum_f else [u / f for u, f in zip(usum_f, FORCES_N)]
        add(f"USUM grows less than linearly with force ({n} cone{'s' if n > 1 else ''}, 1-4 N: USUM/F falls)",
            "4 cones: 4.0 / 5.3 / 6.7 / 7.6 mm" if n == 4 else "-", usum_f, None if per_n is None else
            (_rises(usum_f) and _falls(per_n)))
    for q, paper in (("seqv_pa", "662340 / 448324 / 235490 Pa"), ("eptoeqv", "1.57 / 1.42 / 1.24")):
        vals = series(results, q, (2, 3, 4), [1.0])
        alt = series(results, q, (2, 3, 4), [1.0], alt=True)
        add(f"{q.split('_')[0].upper()} falls with the number of cones (1 N, 2-4 cones)", paper, vals, _falls(vals),
            alt, _falls(alt))
    for q, paper in (("seqv_pa", "(235.49) / 587.78 / 1100 / 2450 kPa"), ("eptoeqv", "1.24 / 1.57 / 1.85 / 2.03")):
        vals = series(results, q, [4], FORCES_N)
        alt = series(results, q, [4], FORCES_N, alt=True)
        add(f"{q.split('_')[0].upper()} grows with force (4 cones, 1-4 N)", paper, vals, _rises(vals), alt, _rises(alt))
    return out


def missing_values(rows: list[dict[str, Any]]) -> list[str]:
    """The paper values (misprints aside) the run has no value of ours for: the study's missing deliverables."""
    return [f"{r['source']} {r['quantity']}, {r['cones']} cone(s) at {r['force_n']:g} N" for r in rows
            if r["note"] is None and r["ours"] is None]


def findings(stopped: dict[int, str], rows: list[dict[str, Any]]) -> list[str]:
    """Each cone count whose ramp stopped, and whether every value the paper gives for it was reached first."""
    out = []
    for n, why in sorted(stopped.items()):
        lost = [r for r in rows if r["cones"] == n and r["note"] is None and r["ours"] is None]
        verdict = (f"{len(lost)} of the paper's values for it are missing" if lost else
                   "past every value the paper gives for it")
        out.append(f"{n} cone(s): {why} ({verdict})")
    return out

