"""The pictures: the paper's Figures 2-4 (USUM contours, force against displacement) and the trends.

Figures 2 and 3 share one colour scale across all their panels; the SEQV panels of the trends are on a
log scale, since the rim peak and the maximum outside the rims differ by up to 10 times.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from suture_fem.studies.paper import CONES, FORCES_N, LABELS, PAPER, QUANTITIES
from suture_fem.studies.reproduce.compare import series

#: Shown in the pictures of Figure 2 (4 cones) and Figure 3 (1 N).
FIG2_FORCES_N = (1.0, 3.0, 4.0)


def _panel_title(grid: Any, cones: int, force_n: float) -> str:
    return (f"{cones} cone{'s' if cones > 1 else ''}, {force_n:g} N: "
            f"USUM {float(grid.point_data['usum_mm'].max()):.2f} mm")


def figures(solved: dict[str, Any], out: Path) -> list[Path]:
    """The pictures of the paper's Figures 2-4 and the trends (rank 0)."""
    from suture_fem import plots

    results, grids = solved["results"], solved["grids"]
    written = []
    fig2 = [(4, f) for f in FIG2_FORCES_N if (4, f) in grids]
    fig3 = [(n, 1.0) for n in CONES if (n, 1.0) in grids]
    shown = set(fig2) | set(fig3)  # one colour scale across the panels of both figures
    clim = (0.0, max(float(grids[k].point_data["usum_mm"].max()) for k in shown)) if shown else None
    if fig2:
        written.append(plots.render_usum([grids[k] for k in fig2], out / "fig2_usum_4_cones.png", clim=clim,
                                         titles=[_panel_title(grids[k], *k) for k in fig2],
                                         suptitle="USUM, 4 cones at 1, 3 and 4 N (paper Fig. 2), deformed shape"))
    if fig3:
        written.append(plots.render_usum([grids[k] for k in fig3], out / "fig3_usum_1_n.png", clim=clim,
                                         titles=[_panel_title(grids[k], *k) for k in fig3],
                                         suptitle="USUM at 1 N, 1-4 cones (paper Fig. 3 and 2a), deformed shape"))
    curves = {_cones_label(n): results[n]["force_displacement"] for n in CONES if n in results}
    reference = {_cones_label(n): [[p.force_n, p.value] for p in PAPER if p.quantity == "usum_mm" and p.cones == n]
                 for n in CONES}
    written.append(plots.plot_force_displacement(
        curves, out / "fig4_force_displacement.png", reference, reference_name="paper's USUM",
        title="Force against thread end displacement, ours; the paper's USUM (Table 1, section 2.2)"))
    log_seqv = [LABELS["seqv_pa"] + " in the tissue"]  # the rim peak and the rest differ by up to 10 times
    written.append(plots.plot_trends(CONES, _trend_panels(results, CONES, [1.0]), out / "trends_vs_cones.png",
                                     "number of cones", title="At 1 N, against the number of cones",
                                     log_panels=log_seqv))
    written.append(plots.plot_trends(FORCES_N, _trend_panels(results, [4], FORCES_N), out / "trends_vs_force.png",
                                     "force (N)", title="4 cones, against the pulling force", log_panels=log_seqv))
    return written


def _cones_label(n: int) -> str:
    return f"{n} cone{'s' if n > 1 else ''}"


def _trend_panels(results: dict[int, Any], cones: Any, forces: Any) -> dict[str, dict[str, list]]:
    """One panel per quantity: ours (and ours outside the rims) against the paper's, over cones x forces."""
    panels: dict[str, dict[str, list]] = {}
    for q in QUANTITIES:
        scale = 1e-3 if q == "seqv_pa" else 1.0
        paper = {(p.cones, p.force_n): p.value for p in PAPER if p.quantity == q and not p.typo}
        lines = {"ours": [None if v is None else v * scale for v in series(results, q, cones, forces)]}
        if q != "usum_mm":
            lines["ours, outside rims"] = [None if v is None else v * scale
                                           for v in series(results, q, cones, forces, alt=True)]
        lines["paper"] = [paper[(n, f)] * scale if (n, f) in paper else None for n in cones for f in forces]
        panels[LABELS[q] + (" in the tissue" if q != "usum_mm" else "")] = lines
    return panels
