"""The paper's stress question: does stress fall about 60 % and strain about 20 % from 2 to 4 cones?

The paper (Table 2, 1 N) gives SEQV 662 / 448 / 235 kPa and EPTOEQV 1.57 / 1.42 / 1.24 for 2 / 3 / 4 cones,
and concludes "Increasing the number of cones led to the decrease in the equivalent local strain (around
20 %) and stress (around 60 %)". Its SEQV is a raw maximum at a sharp rim, which has no limit under
refinement. This module compares the paper with the measures that converge: the tissue's
critical-distance averages with the disc's centre near a cone (``seqv_cd_cone_pa``, ``eptoeqv_cd_cone``),
the same over the whole tissue (``seqv_cd_pa``, ``eptoeqv_cd``) and the peak on the resolved fillet
(``seqv_fillet_pa``, ``eptoeqv_fillet``), next to the raw maximum (mesh-dependent), and, with
:func:`ratio_sensitivity`, how the 2-to-4-cone ratios depend on the fillet radius and the critical distance.

The question is about the cones, so the answer in words uses the near-cone averages and the fillet peak.
The tissue-wide averages stay in the table: on the paper scene the strain's largest average is where the
thread leaves the tissue's pulled face, not at a cone, and its fall measures how much less the thread
pulls there when more cones share the load; comparison.md says where each tissue-wide disc sits when it
is not at a cone.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from suture_fem.geometry.regions import WHOLE_TISSUE
from suture_fem.outputs.critical_distance import CONE_NAMES, CONE_ZONE_RADII
from suture_fem.studies.paper import PAPER
from suture_fem.studies.reproduce.stress_errors import error_bar, ratio_error_bar

#: The tissue measures compared: (results.json key under regions.tissue, label).
MEASURES = (
    ("seqv_cd_cone_pa", "SEQV, critical-distance average near a cone"),
    ("seqv_cd_pa", "SEQV, critical-distance average, tissue-wide"),
    ("seqv_fillet_pa", "SEQV, peak on the resolved fillet"),
    ("seqv_pa", "SEQV, raw maximum (mesh-dependent)"),
    ("eptoeqv_cd_cone", "EPTOEQV, critical-distance average near a cone"),
    ("eptoeqv_cd", "EPTOEQV, critical-distance average, tissue-wide"),
    ("eptoeqv_fillet", "EPTOEQV, peak on the resolved fillet"),
    ("eptoeqv", "EPTOEQV, raw maximum (mesh-dependent)"),
)
#: The paper's claim: the fall from 2 to 4 cones, as a fraction of the 2-cone value.
CLAIMED_FALL = {"seqv": 0.60, "eptoeqv": 0.20}
#: The measures the answer in words uses, per quantity: the near-cone average and the fillet peak.
ANSWERED = {"seqv": (CONE_NAMES["seqv_cd_pa"], "seqv_fillet_pa"),
            "eptoeqv": (CONE_NAMES["eptoeqv_cd"], "eptoeqv_fillet")}


def _tissue_at(results: Any, force_n: float) -> dict[str, Any] | None:
    rec = next((r for r in results.get("at_forces", []) if abs(r["force_n"] - force_n) < 1e-9), None)
    return rec["regions"][WHOLE_TISSUE] if rec else None


def paper_table2() -> dict[int, dict[str, float]]:
    """The paper's Table 2 at 1 N: cone count -> {"seqv": Pa, "eptoeqv": -}."""
    out: dict[int, dict[str, float]] = {}
    for p in PAPER:
        if p.source == "Table 2":
            out.setdefault(p.cones, {})["seqv" if p.quantity == "seqv_pa" else "eptoeqv"] = p.value
    return out


def stress_comparison(results: dict[int, Any], force_n: float = 1.0,
                      uncalibrated: dict[int, Any] | None = None) -> dict[str, Any]:
    """Ours against Table 2 at ``force_n``, per cone count and measure, with error bars, and the falls in words.

    ``results``: the cone counts as solved (calibrated, when ``reproduce`` calibrated); ``uncalibrated``:
    the same before the calibration, compared the same way under ``"uncalibrated"``. Each value and
    each 2-to-4-cone fall carries its error bar where a ladder of the case was measured
    (:mod:`~suture_fem.studies.reproduce.stress_errors`, at 1 N only).
    """
    table = paper_table2()
    out = {"force_n": force_n, "paper_fall_2_to_4": _paper_falls(table), **_column(results, force_n, table),
           "error_bars": "relative; the distance to the finest rung of a measured ladder of the case plus the spread "
                         "between its two finest rungs (studies/reproduce/stress_errors.py); falls: the same from "
                         "the 4/2-cone ratio rung by rung"}
    if uncalibrated:
        out["uncalibrated"] = _column(uncalibrated, force_n, table)
    return out


def _column(results: dict[int, Any], force_n: float, table: dict[int, dict[str, float]]) -> dict[str, Any]:
    """Rows (values, error bars, falls) and the answer in words for one set of solved cone counts."""
    rows, falls = [], {}
    counts = sorted(results)
    for key, label in MEASURES:
        tissues = {n: _tissue_at(results[n], force_n) or {} for n in counts}
        values = {n: tissues[n].get(key) for n in counts}
        bars = {n: error_bar(results[n], key) if force_n == 1.0 and values[n] is not None else None for n in counts}
        kind = "seqv" if key.startswith("seqv") else "eptoeqv"
        paper = {n: table.get(n, {}).get(kind) for n in counts}
        fall, fall_bar = None, None
        if values.get(2) and values.get(4) is not None:
            ratio = values[4] / values[2]
            fall = 1 - ratio
            rel = ratio_error_bar(results[2], results[4], key) if force_n == 1.0 else None
            fall_bar = None if rel is None else abs(ratio) * rel
        falls[key] = (fall, fall_bar)
        rows.append({"measure": key, "label": label, "ours": values, "error_rel": bars, "paper": paper,
                     "fall_2_to_4": fall, "fall_error": fall_bar,
                     "at_mm": {n: tissues[n].get(key + "_at_mm") for n in counts}})
    return {"rows": rows, "answer": answer(falls)}


def _paper_falls(table: dict[int, dict[str, float]]) -> dict[str, float]:
    return {k: 1 - table[4][k] / table[2][k] for k in ("seqv", "eptoeqv")}


def _fall_text(measure: str, fall: float | None, bar: float | None) -> str:
    if fall is None:
        return f"{measure}: -"
    return f"{measure}: {100 * fall:.0f}" + ("" if bar is None else f" +- {100 * bar:.2g}") + " %"


def answer(falls: dict[str, Any]) -> str:
    """The answer in words: the falls of the converging measures at the cones against the paper's 60 % and 20 %.

    ``falls``: measure -> fall, or (fall, its error bar or None). The measures of :data:`ANSWERED` are
    used: the critical-distance averages near a cone and the fillet peak (the tissue-wide averages may
    sit away from every cone). A fall within 10 points of the claim is "about" it; one whose error bar
    reaches within 10 points is "not excluded".
    """
    parts = []
    for kind, name in (("seqv", "stress"), ("eptoeqv", "strain")):
        claimed = CLAIMED_FALL[kind]
        found = []
        for m in ANSWERED[kind]:
            f = falls.get(m)
            found.append((m, *(f if isinstance(f, tuple) else (f, None))))
        text = ", ".join(_fall_text(m, f, b) for m, f, b in found)
        present = [(f, b) for _, f, b in found if f is not None]  # no fillet peak with sharp rims
        ok = [abs(f - claimed) <= 0.1 for f, _ in present]
        reachable = [b is not None and abs(f - claimed) - b <= 0.1 for f, b in present]
        verdict = ("not measured" if not present else "yes" if all(ok) else "partly" if any(ok) else
                   "not excluded by the error bars" if any(reachable) else "no")
        parts.append(f"{name} falls about {100 * claimed:.0f} % from 2 to 4 cones? {verdict} ({text}; "
                     f"'about' taken as within 10 points)")
    return "; ".join(parts)


def stress_markdown(stress: dict[str, Any] | None) -> list[str]:
    """comparison.md's section on the paper's stress question (empty without 2 and 4 cones)."""
    if not stress:
        return []
    lines = ["", f"## Stress and strain at {stress['force_n']:g} N (Table 2): the measures that converge", "",
             "Ours +- the error bar (" + stress["error_bars"] + "; `n.m.`: no ladder of the case measured). The "
             "raw maxima are mesh-dependent at a sharp rim (no limit under refinement).", "",
             where_sentence(stress), ""]
    for title, col in _columns(stress, "as solved"):
        lines += [f"**{title}**: {col['answer']}.", "", "| measure | cones | paper | ours | fall 2 to 4 (paper) "
                  "| fall 2 to 4 (ours) |", "| --- | ---: | ---: | ---: | ---: | ---: |"]
        for row in col["rows"]:
            kind = "seqv" if row["measure"].startswith("seqv") else "eptoeqv"
            for n in sorted(row["ours"]):
                raw = row["measure"] in ("seqv_pa", "eptoeqv")  # no limit: no error bar to give
                fall = "" if n != 4 else _fall_cell(row["fall_2_to_4"], "" if raw else row["fall_error"])
                paper_fall = "" if n != 4 else f"{100 * stress['paper_fall_2_to_4'][kind]:.0f} %"
                ours = _value(row["ours"][n], kind, "" if raw else row["error_rel"][n])
                paper = _value(row["paper"][n], kind)
                lines.append(f"| {row['label']} | {n} | {paper} | {ours} | {paper_fall} | {fall} |")
        lines.append("")
    return lines


def _columns(stress: dict[str, Any], alone: str) -> list[tuple[str, dict[str, Any]]]:
    """(title, column): calibrated and uncalibrated when both were solved, else the one column titled ``alone``."""
    if "uncalibrated" not in stress:
        return [(alone, stress)]
    return [("calibrated", stress), ("uncalibrated", stress["uncalibrated"])]


def where_sentence(stress: dict[str, Any]) -> str:
    """One sentence: what the near-cone rows are, and where the tissue-wide averages sit when not at a cone.

    A tissue-wide average is at a cone when its disc is the near-cone one (the same centre); otherwise the
    sentence gives its disc's centre (r, z) per column and cone count.
    """
    away, compared = [], False
    for title, col in _columns(stress, ""):
        rows = {row["measure"]: row for row in col["rows"]}
        for wide, near in CONE_NAMES.items():
            w, c = rows.get(wide, {}).get("at_mm", {}), rows.get(near, {}).get("at_mm", {})
            both_at = [n for n in sorted(w) if w[n] and c.get(n)]
            compared = compared or bool(both_at)
            places = [f"{n} cone{'s' if n != 1 else ''} at ({w[n][0]:.3g}, {w[n][1]:.4g})" for n in both_at
                      if w[n] != c[n]]
            if places:
                label = dict(MEASURES)[wide].split(",")[0]
                away.append(" ".join(filter(None, (label, title))) + " " + ", ".join(places))
    where = ("not at a cone for " + "; ".join(away) + " (r, z in mm: the disc's centre)" if away else
             "at a cone in every case shown (the near-cone disc)" if compared else "(where: not recorded)")
    return (f"The near-cone rows are the largest critical-distance average with the disc's centre within "
            f"{CONE_ZONE_RADII:g} critical distances of a cone's surface (the concentration the cones cause; the "
            f"answer uses them and the fillet peak); the tissue-wide rows are the largest anywhere in the tissue, "
            f"{where}.")


def _value(v: float | None, kind: str, bar: float | None | str = "") -> str:
    if v is None:
        return "-"
    text = f"{v / 1e3:.4g} kPa" if kind == "seqv" else f"{v:.3f}"
    if bar == "":
        return text
    return text + (" (n.m.)" if bar is None else f" +- {100 * bar:.2g} %")


def _fall_cell(fall: float | None, bar: float | None | str) -> str:
    if fall is None:
        return "-"
    return f"{100 * fall:.0f} %" + ("" if bar == "" else " (n.m.)" if bar is None else f" +- {100 * bar:.2g}")


def ratio_sensitivity(scene: Any, comm: Any, fillets_mm: Sequence[float], distances_mm: Sequence[float],
                      force_n: float = 1.0) -> list[dict[str, Any]]:
    """The 4-cone over 2-cone ratio of each converging measure, per fillet radius and critical distance.

    The critical-distance averages are given tissue-wide (``seqv_cd_pa_ratio``, ``eptoeqv_cd_ratio``) and
    near a cone (``seqv_cd_cone_pa_ratio``, ``eptoeqv_cd_cone_ratio``; None where a cone count has no
    near-cone value). One solve per fillet and cone count (to ``force_n``); the critical distances are
    evaluated on the same solved states.
    """
    from suture_fem.outputs.base import State
    from suture_fem.outputs.critical_distance import CriticalDistance
    from suture_fem.pipeline import scene_model

    rows = []
    for fillet in fillets_mm:
        found: dict[int, dict[str, Any]] = {}
        for cones in (2, 4):
            s = scene.with_values({"geometry.cones": cones, "geometry.cone_fillet_mm": fillet,
                                   "loading.force_n": force_n, "loading.report_forces_n": [], "output.fields": False})
            model = scene_model(s, None, comm)
            res = model.solve()
            per: dict[str, Any] = {}
            for _ in model.reports():  # the one reported force, force_n
                for d in distances_mm:
                    tissue = CriticalDistance(model.outputs.setup, radius_mm=d).in_tissue(State(model.outputs.setup))
                    per[d] = {k: v.value for k, v in tissue.items()}
            tissue = _tissue_at(res, force_n) or {}
            found[cones] = {"cd": per, "fillet": {k: tissue.get(k) for k in ("seqv_fillet_pa", "eptoeqv_fillet")}}
        for d in distances_mm:
            row = {"fillet_mm": fillet, "critical_distance_mm": d}
            for k in (*CONE_NAMES, *CONE_NAMES.values()):  # tissue-wide and near a cone
                a, b = found[2]["cd"][d].get(k), found[4]["cd"][d].get(k)
                row[k + "_ratio"] = b / a if a and b is not None else None
            for k in ("seqv_fillet_pa", "eptoeqv_fillet"):
                a, b = found[2]["fillet"][k], found[4]["fillet"][k]
                row[k + "_ratio"] = b / a if a and b else None
            rows.append(row)
    return rows
