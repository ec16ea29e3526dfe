"""comparison.md: the side-by-side table, the trends, the calibration and the run, as Markdown."""

from __future__ import annotations

from typing import Any

from suture_fem.studies.paper import LABELS
from suture_fem.studies.reproduce.calibration import DEFAULT, MEASURED_SCALE
from suture_fem.studies.reproduce.stress import stress_markdown
from suture_fem.studies.reproduce.stress_errors import SCALE_TOLERANCE


def fmt(q: str, v: Any) -> str:
    """A value of quantity ``q`` as shown in the tables (SEQV in kPa); "-" where missing."""
    if v is None:
        return "-"
    if q == "seqv_pa":
        return f"{v / 1e3:.4g} kPa"
    if q == "usum_mm":
        return f"{v:.3f} mm"
    return f"{v:.3f}"


def pct(v: Any) -> str:
    """A relative error as a signed percentage; "-" where missing."""
    return "-" if v is None else f"{100 * v:+.1f} %"


def comparison_markdown(cmp: dict[str, Any], info: dict[str, Any]) -> str:
    """comparison.md: the side-by-side table, the trends, the calibration and the run."""
    lines = [
        "# Mousavi et al., Tables 1 and 2: the paper against suture_fem",
        "",
        f"Scene `{info['scene_name']}`: {info['geometry']}. Mesh per cone count: {_rungs(info)} ({info['dofs']}). "
        f"One load ramp to 4 N per cone count. Wall time of the whole command: {info['wall_time_s']:.1f} s on "
        f"{info['ranks']} MPI rank(s), {info.get('jobs', 1)} ramp(s) at once; "
        f"CPU time {info.get('cpu_time_s', 0):.1f} s "
        f"(this process and its ramps' processes; the ramps {info.get('ramps_cpu_time_s', 0):.1f} s).",
        "",
        "## Calibration",
        "",
        _calibration_text(cmp["calibration"]),
        "",
    ]
    lines += _findings_section(cmp)
    lines += _values_section(cmp) + _relative_usum_section(cmp) + _trends_section(cmp)
    lines += stress_markdown(cmp.get("stress"))  # the converging measures with their error bars
    lines += ["", "## Files", "", "`comparison.json` (everything above), `cones_N/results.json`, `fields/*.vtu`, "
              "`fig2_usum_4_cones.png`, `fig3_usum_1_n.png`, `fig4_force_displacement.png`, `trends_vs_cones.png`, "
              "`trends_vs_force.png`. See docs/reproduction.md.", ""]
    return "\n".join(lines)


def _findings_section(cmp: dict[str, Any]) -> list[str]:
    """Ramps that stopped (findings) and paper values without ours (missing deliverables), when any."""
    lines = []
    if cmp.get("findings"):
        lines += ["## Findings", "", *(f"- {f}" for f in cmp["findings"]), ""]
    if cmp.get("missing"):
        lines += ["## Missing values", "", *(f"- {m}" for m in cmp["missing"]), ""]
    return lines


def _rungs(info: dict[str, Any]) -> str:
    rungs = info.get("rungs") or {}
    if not rungs:
        return f"degree {info['mesh']['degree']}, refinement {info['mesh']['refinement']}"
    return "; ".join(f"{n} cone{'s' if n != '1' else ''} {label}" for n, label in rungs.items())


def _discretisation(r: dict[str, Any]) -> str:
    """USUM's estimated discretisation error on its rung, as shown after the value ("" where none)."""
    e = r.get("usum_discretisation_error")
    return "" if not e else f" (mesh {pct(e['rel'])})"


def _discretisation_text(cmp: dict[str, Any]) -> str:
    errs = cmp.get("usum_discretisation_errors") or []
    if not errs:
        return ""
    hows = sorted({f"{e['cones']} cone{'s' if e['cones'] > 1 else ''} ({e['rung']}) {e['estimate']}" for e in errs})
    worst = max(errs, key=lambda e: abs(e["rel"]))
    softer = (" A calibrated, softer tissue deforms more and the error grows: at materials.tissue_scale 0.3112 the "
              "4-cone P1 r0 USUM is 0.59 / 0.75 / 0.87 / 0.98 % below P2 r0 at 1 / 2 / 3 / 4 N (uncalibrated: 0.49 / "
              "0.52 / 0.58 / 0.63 %), so the calibrated values' errors are about 1.2-1.6 times those shown (4 cones, "
              "4 N: about -1.1 %)."
              if _near_measured_calibration(cmp["calibration"]) else
              " A calibrated scene's errors were not measured: a softer tissue deforms more, and the error grows "
              "(docs/speed.md)." if cmp["calibration"].get("status") == "calibrated" else "")
    return (" \"(mesh x %)\" after a USUM is its estimated relative discretisation error on the mesh rung it was "
            "solved on (negative: below the mesh-converged value), measured on the uncalibrated scene "
            f"(docs/speed.md); largest {pct(worst['rel'])} ({worst['cones']} cones, {worst['force_n']:g} N). "
            "Estimated: " + "; ".join(hows) + "." + softer)


def calibration_heading(cal: dict[str, Any]) -> str:
    """The calibrated parameter with its 95 % interval, for the table's heading (or why nothing is)."""
    if cal.get("status") == "calibrated":
        return (f"calibrated: `{cal['key']}` = {cal['value']:.5g}, 95 % interval [{cal['ci95'][0]:.5g}, "
                f"{cal['ci95'][1]:.5g}] (on USUM {cal['target']['printed']}, {cal['target']['cones']} cones, "
                f"{cal['target']['force_n']:g} N; the interval from the paper's printed precision)")
    if cal.get("status") == "not calibrated":
        return "nothing calibrated (--calibrate none): every value is a prediction"
    return f"`{cal['key']}` could not reach the target: nothing calibrated, every value is a prediction"


def _values_section(cmp: dict[str, Any]) -> list[str]:
    """Every paper value with ours, the errors and the role; what is not used; the largest prediction error."""
    two = cmp["calibration"].get("status") == "calibrated"  # the uncalibrated and the calibrated columns
    head = ("| source | cones | force | quantity | paper | uncalibrated | error | calibrated | error | "
            "calibrated, outside rims | error | role |") if two else (
            "| source | cones | force | quantity | paper | ours | error | ours, outside rims | error | role |")
    lines = [
        f"## Values: {calibration_heading(cmp['calibration'])}",
        "",
        "Error = (model - paper) / paper. The model's value is the measure the paper reports (USUM: maximum over "
        "the model; SEQV and EPTOEQV: maximum over the tissue, which includes the peak at the sharp cone rims); "
        "\"outside rims\" is " + cmp["measures"]["outside_rims"] + "."
        + (" A calibrated USUM carries its linearised 95 % band (+-) where one was propagated." if two else "")
        + _discretisation_text(cmp),
        "",
        head,
        "|" + " --- |" * (head.count("|") - 1),
    ]
    for r in cmp["rows"]:
        q = r["quantity"]
        cal = fmt(q, r["ours"]) + (f" +- {r['band95']:.3f}" if r.get("band95") is not None else "")
        cal += _discretisation(r)
        before = fmt(q, r["uncalibrated"]) + _discretisation(r)
        first = f"{before} | {pct(r['uncalibrated_rel_error'])} | " if two else ""
        lines.append(
            f"| {r['source']} | {r['cones']} | {r['force_n']:g} N | {LABELS[q].split(' ')[0]} | {r['paper_printed']} "
            f"| {first}{cal} | {pct(r['rel_error'])} | {fmt(q, r['ours_outside_rims'])} | "
            f"{pct(r['rel_error_outside_rims'])} | {r['role']} |"
        )
    not_used = [f"{r['source']}, {r['cones']} cones, {r['force_n']:g} N, SEQV {r['paper_printed']} ({r['note']})"
                for r in cmp["rows"] if r["note"]]
    lines += ["", "Not used: " + "; ".join(not_used) + "."]
    w, wa = cmp["largest_prediction_error"], cmp["largest_prediction_error_outside_rims"]
    if w:
        lines += ["", f"Largest prediction error: {pct(w['rel_error'])} ({w['source']}, {LABELS[w['quantity']]}, "
                      f"{w['cones']} cones, {w['force_n']:g} N)."]
    if wa:
        lines[-1] += (f" With the measures outside the rims: {pct(wa['rel_error_outside_rims'])} "
                      f"({wa['source']}, {LABELS[wa['quantity']]}, {wa['cones']} cones, {wa['force_n']:g} N).")
    return lines


def _relative_usum_section(cmp: dict[str, Any]) -> list[str]:
    """USUM relative to the calibration case: how it changes with cones and force, apart from its level."""
    lines = ["", "USUM relative to the 4-cone, 1 N case (paper / 4.0 mm against ours / ours at 4 cones, 1 N): how "
             "USUM changes with cones and force, apart from the overall level.", "",
             "| source | cones | force | paper | ours | error |", "| --- | --- | --- | --- | --- | --- |"]
    for r in cmp["usum_relative_to_target"]:
        lines.append(f"| {r['source']} | {r['cones']} | {r['force_n']:g} N | {r['paper']:.3f} | {r['ours']:.3f} | "
                     f"{pct(r['rel_error'])} |")
    return lines


def _trends_section(cmp: dict[str, Any]) -> list[str]:
    """The paper's trends, ours, and whether they hold (also with the measures outside the rims)."""
    lines = ["", "## Trends", "", "| trend | paper | ours | holds | ours, outside rims | holds |",
             "| --- | --- | --- | --- | --- | --- |"]
    for t in cmp["trends"]:
        q = "seqv_pa" if t["trend"].startswith("SEQV") else "eptoeqv" if t["trend"].startswith("EPTOEQV") else "usum_mm"
        vals = " / ".join(fmt(q, v) for v in t["ours"])
        alt = " / ".join(fmt(q, v) for v in t["ours_outside_rims"]) if t["ours_outside_rims"] else "-"
        lines.append(f"| {t['trend']} | {t['paper']} | {vals} | {_yes(t['holds'])} | {alt} | "
                     f"{_yes(t['holds_outside_rims'])} |")
    return lines


def _yes(v: Any) -> str:
    return "-" if v is None else ("yes" if v else "**no**")


def _calibration_text(cal: dict[str, Any]) -> str:
    if cal.get("status") == "not calibrated":
        return ("Nothing calibrated (`--calibrate none`): the scene's values as they are, every paper value a "
                "prediction.")
    head = (f"`{cal['key']}` fitted to USUM {cal['target']['printed']} at {cal['target']['cones']} cones, "
            f"{cal['target']['force_n']:g} N (bounded least squares of `suture-fem calibrate`, sensitivity: "
            f"{cal['sensitivity']}; bounds [{cal['bounds'][0]:g}, {cal['bounds'][1]:g}], start {cal['start']:g}).")
    if cal["status"] == "calibrated":
        head += (f" Calibrated: {cal['value']:.6g}, 95 % interval [{cal['ci95'][0]:.6g}, {cal['ci95'][1]:.6g}], "
                 f"USUM {cal['usum_mm']:.4f} mm in the fit ({cal['usum_mm_in_this_run']:.4f} mm in this run). "
                 f"One value determines one parameter exactly, so the interval is {cal['uncertainty_from']}. "
                 f"Predicted USUM bands: {cal.get('bands', '-')}.")
    else:
        head += (f" Unreachable: the fit ends at {cal['value']:.6g} (a bound) with USUM {cal['usum_mm']:.4f} mm "
                 f"({pct(cal['rel_error'])}); nothing was moved, every value is a prediction.")
    c = cal["cost"]
    return (head + f" Cost of the calibration: {c['evaluations']} evaluations, {c['ramps']} load ramps, "
            f"{c['newton_iterations']} Newton iterations, {c['cpu_time_s']:.0f} s CPU "
            f"({c['total_wall_time_s']:.0f} s wall); `calibration/calibration.json`.")


def _near_measured_calibration(cal: dict[str, Any]) -> bool:
    """A calibrated tissue scale that is MEASURED_SCALE (within SCALE_TOLERANCE): its errors were measured."""
    return (cal.get("status") == "calibrated" and cal.get("key") == DEFAULT
            and abs(float(cal.get("value", 0.0)) / MEASURED_SCALE - 1.0) <= SCALE_TOLERANCE)
