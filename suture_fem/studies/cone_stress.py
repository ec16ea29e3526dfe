"""A picture of the tissue's von Mises stress around one cone, with the peaks, the averaging disc and the fillet.

``cone_stress_picture`` solves a scene once (a Model) and draws, from its state at its last reported force,
the cone of the tissue's largest critical-distance average near a cone (``seqv_cd_cone_pa``; else of the
fillet peak, else of the raw maximum): the whole cone and a zoom on that disc, the raw maximum
(mesh-dependent), the peak on the resolved fillet, the averaging disc and the fillet arcs.
``benchmarks/cone_stress_picture.py`` draws docs/cone-stress.png with it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.geometry import regions
from suture_fem.geometry.regions import WHOLE_TISSUE
from suture_fem.plots import _save, field_grid, file_figure


def plot_cone_stress(grid: Any, record: Mapping[str, Any], cone: Mapping[str, Any], arcs: Sequence[Sequence[Any]],
                     radius_mm: float, png: str | Path) -> Path:
    """The tissue's von Mises stress around one cone: the peaks, the averaging disc and the fillet arcs.

    Args:
        grid: :func:`field_grid` of the solved state (x = z, y = r, cell data ``von_mises_pa`` and ``region``).
        record: one ``at_forces`` record of results.json (its ``regions.tissue`` peaks and disc centre).
        cone: the cone's ``base_z_mm`` and ``apex_z_mm`` (results.json ``geometry.cones``).
        arcs: the cone's fillet arcs as (start, centre, end) points (r, z) in mm.
        radius_mm: the averaging disc's radius (``output.critical_distance_mm``).
        png: the picture's path.
    """
    from matplotlib.collections import PolyCollection
    from matplotlib.colors import LogNorm

    tissue = record["regions"][WHOLE_TISSUE]
    base = cone["base_z_mm"]
    lo, hi = min(base, cone["apex_z_mm"]), max(base, cone["apex_z_mm"])
    rim = _focus(tissue)
    windows = [((lo - 0.4, hi + 0.4), (0.0, 1.2)), ((rim[1] - 0.2, rim[1] + 0.2), (rim[0] - 0.2, rim[0] + 0.2))]
    cells = grid.cells_dict
    fig = file_figure(figsize=(12, 5))
    for k, ((z0, z1), (r0, r1)) in enumerate(windows):
        ax = fig.add_subplot(1, 2, k + 1)
        for kind, conn in cells.items():
            offset = sum(len(c) for t, c in cells.items() if t < kind)  # cells_dict groups cells by type, in order
            tri = grid.points[conn[:, :3], :2]
            mids = tri.mean(axis=1)
            keep = (mids[:, 0] > z0 - 0.1) & (mids[:, 0] < z1 + 0.1) & (mids[:, 1] > r0 - 0.1) & (mids[:, 1] < r1 + 0.1)
            ids = offset + np.nonzero(keep)[0]
            in_tissue = np.isin(grid.cell_data["region"][ids], list(regions.TISSUE))
            vm = np.maximum(grid.cell_data["von_mises_pa"][ids], 1.0)
            coll = PolyCollection(tri[keep][in_tissue], array=vm[in_tissue], cmap="viridis", edgecolors="face",
                                  linewidths=0.1 if k else 0.0, norm=LogNorm(vmin=max(vm[in_tissue].min(), 1e2),
                                                                             vmax=vm[in_tissue].max()))
            ax.add_collection(coll)
            ax.add_collection(PolyCollection(tri[keep][~in_tissue], facecolors="0.75", edgecolors="0.6",
                                             linewidths=0.1))
        fig.colorbar(coll, ax=ax, label="von Mises stress (Pa), per cell maximum")
        _marks(ax, tissue, arcs, radius_mm)
        ax.set_xlim(z0, z1)
        ax.set_ylim(r0, r1)
        ax.set_aspect("equal")
        ax.set_xlabel("z (mm)")
        ax.set_ylabel("r (mm)")
        ax.set_title("around the cone" if k == 0 else "around the averaging disc")
        if k:
            ax.legend(loc="upper left", fontsize=7)
    fig.suptitle(f"tissue von Mises stress at {record['force_n']:g} N")
    return _save(fig, png)


def _marks(ax: Any, tissue: Mapping[str, Any], arcs: Sequence[Sequence[Any]], radius_mm: float) -> None:
    """The fillet arcs, the raw and fillet peaks and the averaging disc (x = z, y = r)."""
    from matplotlib.patches import Circle

    for a, c, b in arcs:
        ax.plot([a[1], c[1], b[1]], [a[0], c[0], b[0]], "r:", lw=0.8)
        ax.plot(c[1], c[0], "r+", ms=6)
    for key, marker, label in (("seqv_pa", "kx", "raw maximum (mesh-dependent)"),
                               ("seqv_fillet_pa", "r^", "peak on the resolved fillet")):
        at = tissue.get(key + "_at_mm")
        if at:
            ax.plot(at[1], at[0], marker, ms=8, label=f"{label}: {tissue[key] / 1e3:.4g} kPa")
    key = "seqv_cd_cone_pa" if tissue.get("seqv_cd_cone_pa_at_mm") else "seqv_cd_pa"
    centre = tissue.get(key + "_at_mm")
    if centre:
        where = "near a cone" if key == "seqv_cd_cone_pa" else "tissue's largest"
        ax.add_patch(Circle((centre[1], centre[0]), radius_mm, fill=False, ec="w", lw=1.5,
                            label=f"averaging disc ({where}) R = {radius_mm:g} mm: {tissue[key] / 1e3:.4g} kPa"))


def _focus(tissue: Mapping[str, Any]) -> list[float]:
    """Where the picture looks, (r, z) mm: the near-cone disc, else the fillet peak, else the raw maximum."""
    return (tissue.get("seqv_cd_cone_pa_at_mm") or tissue.get("seqv_fillet_pa_at_mm")
            or tissue["seqv_pa_at_mm"])


def cone_stress_picture(scene: Any, png: str | Path, comm: Any) -> Path | None:
    """Solve ``scene`` and draw the stress around the cone of :func:`_focus` (rank 0 draws; collective)."""
    from suture_fem.geometry.section import Geometry
    from suture_fem.pipeline import scene_model

    model = scene_model(scene, None, comm)
    results = model.solve()
    with model.at(results.at_forces[-1].force_n) as record:
        grid = field_grid(model.outputs)
    if comm.rank != 0:
        return None
    geometry = Geometry.from_section(scene.geometry)
    tissue = record["regions"][WHOLE_TISSUE]
    at = _focus(tissue)
    cone = min(geometry.cones, key=lambda c: abs(0.5 * (c.base_z + c.apex_z) - at[1]))
    arcs = [seg for kind, seg in cone.outline if kind == "arc"]
    return plot_cone_stress(grid, record, {"base_z_mm": cone.base_z, "apex_z_mm": cone.apex_z},
                            arcs, scene.output.critical_distance_mm, png)
