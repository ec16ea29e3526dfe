"""The paper's stress question: does stress fall about 60 % and strain about 20 % from 2 to 4 cones?

The paper (Table 2, 1 N) gives SEQV 662 / 448 / 235 kPa and EPTOEQV 1.57 / 1.42 / 1.24 for 2 / 3 / 4 cones,
and concludes "Increasing the number of cones led to the decrease in the equivalent local strain (around
20 %) and stress (around 60 %)". Its SEQV is a raw maximum at a sharp rim, which has no limit under
refinement. This module compares the paper with the measures that converge (issue 17): the tissue's
critical-distance average (``seqv_cd_pa``, ``eptoeqv_cd``) and the peak on the resolved fillet
(``seqv_fillet_pa``, ``eptoeqv_fillet``), next to the raw maximum (mesh-dependent), and, with
:func:`ratio_sensitivity`, how the 2-to-4-cone ratios depend on the fillet radius and the critical distance.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from suture_fem.studies.reproduce.paper import PAPER

#: The tissue measures compared: (results.json key under regions.tissue, label).
MEASURES = (
    ("seqv_cd_pa", "SEQV, critical-distance average"),
    ("seqv_fillet_pa", "SEQV, peak on the resolved fillet"),
    ("seqv_pa", "SEQV, raw maximum (mesh-dependent)"),
    ("eptoeqv_cd", "EPTOEQV, critical-distance average"),
    ("eptoeqv_fillet", "EPTOEQV, peak on the resolved fillet"),
    ("eptoeqv", "EPTOEQV, raw maximum (mesh-dependent)"),
)
#: The paper's claim: the fall from 2 to 4 cones, as a fraction of the 2-cone value.
CLAIMED_FALL = {"seqv": 0.60, "eptoeqv": 0.20}


def _tissue_at(results: Any, force_n: float) -> dict[str, Any] | None:
    rec = next((r for r in results.get("at_forces", []) if abs(r["force_n"] - force_n) < 1e-9), None)
    return rec["regions"]["tissue"] if rec else None


def paper_table2() -> dict[int, dict[str, float]]:
    """The paper's Table 2 at 1 N: cone count -> {"seqv": Pa, "eptoeqv": -}."""
    out: dict[int, dict[str, float]] = {}
    for p in PAPER:
        if p.source == "Table 2":
            out.setdefault(p.cones, {})["seqv" if p.quantity == "seqv_pa" else "eptoeqv"] = p.value
    return out


def stress_comparison(results: dict[int, Any], force_n: float = 1.0) -> dict[str, Any]:
    """Ours against Table 2 at ``force_n``, per cone count and measure, and the 2-to-4-cone falls in words."""
    table = paper_table2()
    rows, falls = [], {}
    for key, label in MEASURES:
        values = {n: (_tissue_at(results[n], force_n) or {}).get(key) for n in sorted(results)}
        kind = "seqv" if key.startswith("seqv") else "eptoeqv"
        paper = {n: table.get(n, {}).get(kind) for n in sorted(results)}
        fall = (1 - values[4] / values[2]) if values.get(2) and values.get(4) else None
        falls[key] = fall
        rows.append({"measure": key, "label": label, "ours": values, "paper": paper, "fall_2_to_4": fall})
    return {"force_n": force_n, "rows": rows, "paper_fall_2_to_4": _paper_falls(table),
            "answer": answer(falls)}


def _paper_falls(table: dict[int, dict[str, float]]) -> dict[str, float]:
    return {k: 1 - table[4][k] / table[2][k] for k in ("seqv", "eptoeqv")}


def answer(falls: dict[str, float | None]) -> str:
    """The answer in words: the falls of the converging measures against the paper's 60 % and 20 %."""
    parts = []
    for kind, name in (("seqv", "stress"), ("eptoeqv", "strain")):
        claimed = CLAIMED_FALL[kind]
        found = [(m, falls.get(m)) for m in (f"{kind}_cd" + ("_pa" if kind == "seqv" else ""),
                                             f"{kind}_fillet" + ("_pa" if kind == "seqv" else ""))]
        text = ", ".join(f"{m}: {'-' if f is None else f'{100 * f:.0f} %'}" for m, f in found)
        ok = [f is not None and abs(f - claimed) <= 0.1 for _, f in found]
        verdict = "yes" if all(ok) else ("partly" if any(ok) else "no")
        parts.append(f"{name} falls about {100 * claimed:.0f} % from 2 to 4 cones? {verdict} ({text}; "
                     f"'about' taken as within 10 points)")
    return "; ".join(parts)


def ratio_sensitivity(scene: Any, comm: Any, fillets_mm: Sequence[float], distances_mm: Sequence[float],
                      force_n: float = 1.0) -> list[dict[str, Any]]:
    """The 4-cone over 2-cone ratio of each converging measure, per fillet radius and critical distance.

    One solve per fillet and cone count (to ``force_n``); the critical distances are evaluated on the
    same solved states.
    """
    from suture_fem.outputs.base import State
    from suture_fem.outputs.critical_distance import CriticalDistance
    from suture_fem.pipeline import run_scene

    rows = []
    for fillet in fillets_mm:
        found: dict[int, dict[str, Any]] = {}
        for cones in (2, 4):
            s = scene.with_values({"geometry.cones": cones, "geometry.cone_fillet_mm": fillet,
                                   "loading.force_n": force_n, "loading.report_forces_n": [], "output.fields": False})
            per: dict[str, Any] = {}

            def on_report(f: float, outputs: Any, per: dict[str, Any] = per) -> None:
                for d in distances_mm:
                    tissue = CriticalDistance(outputs.setup, radius_mm=d).in_tissue(State(outputs.setup))
                    per[d] = {k: v.value for k, v in tissue.items()}

            res = run_scene(s, None, comm, on_report=on_report)
            tissue = _tissue_at(res, force_n) or {}
            found[cones] = {"cd": per, "fillet": {k: tissue.get(k) for k in ("seqv_fillet_pa", "eptoeqv_fillet")}}
        for d in distances_mm:
            row = {"fillet_mm": fillet, "critical_distance_mm": d}
            for k in ("seqv_cd_pa", "eptoeqv_cd"):
                row[k + "_ratio"] = found[4]["cd"][d][k] / found[2]["cd"][d][k]
            for k in ("seqv_fillet_pa", "eptoeqv_fillet"):
                a, b = found[2]["fillet"][k], found[4]["fillet"][k]
                row[k + "_ratio"] = b / a if a and b else None
            rows.append(row)
    return rows
