"""The calibration's Markdown report and its picture (data with error bars, the fitted curve and its band)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.support.io import save_figure


def _g(v: float) -> str:
    return f"{v:.4g}"


def markdown(rec: dict[str, Any]) -> str:
    """calibration.md: the parameters with their intervals, the verdict, the residuals, the cost."""
    lines = ["# Calibration", "", f"Fit: {rec['status']} ({rec['message']}).", "",
             "| parameter | value | 95 % interval | bounds | sensitivity |", "| --- | --- | --- | --- | --- |"]
    for key, p in rec["parameters"].items():
        flag = " (at a bound)" if p["at_bound"] else ""
        lines.append(f"| `{key}` | {_g(p['value'])}{flag} | [{_g(p['ci95'][0])}, {_g(p['ci95'][1])}] | "
                     f"[{_g(p['bounds'][0])}, {_g(p['bounds'][1])}] | {p['sensitivity']} |")
    ident = rec["identifiability"]
    lines += ["", f"Intervals from {rec['uncertainty_from']}; linearised (Gauss-Newton) at the optimum.", "",
              f"Identifiability: {ident['verdict']}.", ""]
    names = list(rec["parameters"])
    if len(names) > 1:
        lines += ["Correlation:", "", "| | " + " | ".join(f"`{n}`" for n in names) + " |",
                  "| --- |" + " --- |" * len(names)]
        for n, row in zip(names, rec["correlation"]):
            lines.append(f"| `{n}` | " + " | ".join(f"{c:+.3f}" for c in row) + " |")
        lines.append("")
    lines += ["| data | force | measured | model | residual |", "| --- | --- | --- | --- | --- |"]
    for d, y, r in zip(rec["data"], rec["predictions_mm"], rec["residuals_mm"]):
        lines.append(f"| {d['label']} | {d['force_n']:g} N | {d['value_mm']:g} mm | {y:.4f} mm | {r:+.4f} mm |")
    lines += _propagated(rec)
    c = rec["cost"]
    lines += ["", f"Cost: {c['evaluations']} evaluations, {c['ramps']} load ramps, {c['meshes']} meshes, "
                  f"{c['newton_iterations']} Newton iterations (the sensitivities reuse their factorisations), "
                  f"{c['cpu_time_s']:.0f} s CPU ({c['total_wall_time_s']:.0f} s wall).", ""]
    return "\n".join(lines)


#: Names of the predicted quantities in the report.
NAMES = {"thread_end_displacement_mm": "thread end displacement", "usum_mm": "USUM",
         "seqv_cd_pa": "tissue SEQV, critical-distance average",
         "eptoeqv_cd": "tissue EPTOEQV, critical-distance average"}


def _with_unit(value: float, unit: str) -> str:
    if unit == "Pa":
        return f"{value / 1e3:.4g} kPa"
    return f"{value:.4f} mm" if unit == "mm" else f"{value:.4g}"


def _propagated(rec: dict[str, Any]) -> list[str]:
    """The predictions at the fitted parameters with their linearised 95 % bands (curve, USUM, stress measures)."""
    if not rec.get("curve"):
        return []
    lines = ["", "Predictions at the fitted parameters, each with its linearised 95 % band (the parameters' "
             "covariance through the sensitivities: direct method for the displacements; for the stress measures "
             "the direct method's du/dp through a central difference of the output map, no extra solve):", "",
             "| cones | force | quantity | model | 95 % band |", "| --- | --- | --- | --- | --- |"]
    for c in rec["curve"]:
        name, unit = NAMES.get(c["quantity"], c["quantity"]), c["unit"]
        for f, y, h in zip(c["force_n"], c["model"], c["band95"]):
            lines.append(f"| {c['cones'] if c['cones'] is not None else '-'} | {f:.4g} N | {name} | "
                         f"{_with_unit(y, unit)} | +- {_with_unit(h, unit)} |")
    return lines


def picture(rec: dict[str, Any], path: Path) -> Path:
    """The data with their error bars, the fitted curve and its 95 % band."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.5))
    quantity = rec["data"][0]["quantity"]
    for curve in (c for c in rec.get("curve", []) if c["quantity"] == quantity):
        f, y, h = (np.array(curve[k]) for k in ("force_n", "model", "band95"))
        label = f"model ({curve['cones']} cones)" if curve["cones"] is not None else "model"
        line, = ax.plot(f, y, label=label)
        ax.fill_between(f, y - h, y + h, color=line.get_color(), alpha=0.25)
    sigma = rec.get("sigma_mm")
    for d in rec["data"]:
        err = d["sd_mm"] if d["sd_mm"] is not None else (sigma if sigma is not None else d["resolution_mm"] / 2)
        ax.errorbar(d["force_n"], d["value_mm"], yerr=err, fmt="o", color="k", capsize=3)
    ax.set_xlabel("force (N)")
    ax.set_ylabel("USUM (mm)" if quantity == "usum_mm" else "thread end displacement (mm)")
    ax.set_title("data (error bars) and the fitted model with its 95 % band", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        return save_figure(fig, path, dpi=120)  # complete or absent: a kill never leaves a 0-byte picture
    finally:
        plt.close(fig)
