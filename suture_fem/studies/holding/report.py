"""The holding study's files: holding.json, holding.md and failure_index.png, and where a failure sits.

:func:`which_cone` names the cone a failure's position belongs to (``cone_1`` farthest from the pulled
end, as ``load_share_n`` names them): the disc's centre within :data:`CONE_ZONE_RADII` critical
distances of the cone's axial extent and of its base radius, else none (the bare thread, or the
thread's exit from the pulled face). The picture colours each tissue cell by its largest pointwise
stress (or strain) over its layer's strength at the first reported force past the failure; the
criterion itself uses the critical-distance average, which is lower than the pointwise peak.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.geometry.regions import REGION_TAGS
from suture_fem.geometry.section import Geometry
from suture_fem.outputs.critical_distance import CONE_ZONE_RADII
from suture_fem.scene.strength import LAYERS
from suture_fem.support.io import save_figure, write_json, write_text
from suture_fem.support.parallel import on_root


def which_cone(scene: Any, at_mm: list[float] | None) -> str | None:
    """The cone (``cone_k``) nearest a failure at ``at_mm`` (r, z), if it lies in that cone's zone."""
    geometry = Geometry.from_section(scene.geometry)
    if at_mm is None or not geometry.cones:
        return None
    reach = CONE_ZONE_RADII * scene.output.critical_distance_mm
    r_base, (r, z) = scene.geometry.cone_base_diameter_mm / 2, at_mm
    best, name = np.inf, None
    for k, cone in enumerate(geometry.cones, start=1):
        lo, hi = sorted((cone.base_z, cone.apex_z))
        dz = max(lo - z, 0.0, z - hi)
        if dz <= reach and r <= r_base + reach and dz < best:
            best, name = dz, f"cone_{k}"
    return name


def where_words(record: dict[str, Any], geometry: Geometry) -> str:
    """Where the first failure is, in words."""
    if record["mode"] == "thread":
        return "the thread breaks (its whole length carries the pull)"
    r, z = record["at_mm"]
    if record["cone"]:
        return f"in the {record['layer']} at {record['cone']} (r = {r:.3f} mm, z = {z:.3f} mm)"
    place = "where the thread leaves the pulled face" if z >= geometry.length - 1.0 else "along the bare thread"
    return f"in the {record['layer']} {place} (r = {r:.3f} mm, z = {z:.3f} mm)"


def _n(value: float | None, above: float) -> str:
    return f"{value:.3g} N" if value is not None else f"> {above:.3g} N"


def markdown(record: dict[str, Any], geometry: Geometry, scene_name: str) -> str:
    """holding.md: the answer in words, the bracket, the band, each part's own failure force, the passes."""
    reached = record["reached_n"]
    lines = [f"# Holding strength: {scene_name}", ""]
    if record["force_n"] is None:
        lines += [f"No part reaches its strength: {record['note']}.", ""]
    else:
        lo, hi = record["bracket_n"]
        lines += [f"The first failure comes at **{record['force_n']:.3g} N** (bracket {lo:.4g} - {hi:.4g} N): "
                  f"{where_words(record, geometry)}.", "",
                  f"Band from the strengths' published spread: {_n(record['band_n'][0], reached)} - "
                  f"{_n(record['band_n'][1], reached)} (first failure with every strength at the low end of its "
                  f"band: {record['band_modes'][0]}; at the high end: {record['band_modes'][1]}).", ""]
    lines += [f"Criterion: `{record['criterion']}` (critical-distance average against the layer's strength; the "
              "thread against its breaking force). Each part on its own, at its strength's value:", "",
              "| part | strength | fails at |", "| --- | --- | --- |"]
    unit = "Pa" if record["criterion"] == "stress" else "(Hencky)"
    for part, force in record["parts_n"].items():
        value = record["strengths"]["value"][part]
        lines.append(f"| {part} | {value:.4g} {'N' if part == 'thread' else unit} | {_n(force, reached)} |")
    lines += ["", "| pass | ramp to (N) | reports | CPU (s) | stopped |", "| --- | --- | --- | --- | --- |"]
    lines += [f"| {i} | {p['to_n']:.4g} | {p['reports']} | {p['cpu_s']} | {p['stopped'] or ''} |"
              for i, p in enumerate(record["passes"], start=1)]
    if record.get("calibration"):
        values = ", ".join(f"{k} = {v:.4g}" for k, v in record["calibration"]["parameters"].items())
        lines += ["", f"Calibrated: {values}; the band includes the first failure at both ends of each 95 % interval "
                  "(at the strengths' low, value and high ends)."]
    if record.get("stop"):
        lines += ["", f"The ramp stopped at {record['stop']['force_n']:.4g} N ({record['stop']['cause']}): "
                  "beyond it the model gives no state, so a failure force above it is unknown."]
    return "\n".join(lines) + "\n"


def failure_index_picture(model: Any, record: dict[str, Any], png: Path) -> Path | None:
    """failure_index.png: each tissue cell's pointwise measure over its layer's strength (collective)."""
    import matplotlib.colors as mcolors

    from suture_fem import plots_fields

    grid = plots_fields.field_section(model, deformed=False)  # the reference shape, where at_mm is
    if grid is None:
        return None
    field = "von_mises_pa" if record["criterion"] == "stress" else "eptoeqv"
    index = np.zeros(grid.n_cells)
    for layer in LAYERS:
        cells = np.isin(grid.cell_data["region"], REGION_TAGS[layer])
        index[cells] = grid.cell_data[field][cells] / record["strengths"]["value"][layer]
    grid.cell_data["failure_index"] = np.maximum(index, 1e-3)
    force = record["bracket_n"][1] if record["bracket_n"] else record["reached_n"]
    whole = plots_fields.bounds_of(grid)
    panels = [(whole, f"{force:.4g} N: pointwise {field} / the layer's strength (red: beyond)")]
    if record["at_mm"] is not None:  # and around the failure, where the critical-distance disc sits
        r, z = record["at_mm"]
        panels.append(((z - 2.0, z + 2.0, -2.0, 2.0), f"at the failure: r = {r:.2f}, z = {z:.2f} mm"))
    fig = _panels(grid, panels, mcolors.LogNorm(0.1, 10.0), "RdYlBu_r")
    import matplotlib.pyplot as plt

    save_figure(fig, png, dpi=130, bbox_inches="tight")  # a temporary file renamed into place: complete or absent
    plt.close(fig)
    return png


def _panels(grid: Any, panels: list[tuple[Any, str]], norm: Any, cmap: str) -> Any:
    """A pyplot figure of ``grid``'s failure index, one panel per (bounds, title), each its own view."""
    import matplotlib.pyplot as plt

    from suture_fem import plots_fields

    ratios = [(b[1] - b[0]) / (b[3] - b[2]) for b, _ in panels]
    fig, axes = plt.subplots(1, len(panels), figsize=(3.6 * sum(ratios) + 1.5, 4.2), squeeze=False,
                             layout="constrained", width_ratios=ratios)
    for ax, (bounds, title) in zip(axes[0], panels):
        ax.imshow(plots_fields.render(grid, "failure_index", norm, cmap, bounds, tissue_only=True, width_px=1400),
                  extent=bounds, interpolation="antialiased")
        ax.set_title(title, fontsize=10, loc="left")
        ax.set_ylabel("r (mm)")
        ax.set_aspect("equal")
        ax.set_xlabel("z (mm), undeformed; pulled toward +z")
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes[0].tolist(),
                 label="failure index (-), log scale", fraction=0.04, pad=0.01)
    return fig


def write(out: Path, record: dict[str, Any], scene: Any, scene_name: str, comm: Any) -> None:
    """holding.json and holding.md into ``out`` (collective; written by rank 0)."""
    geometry = Geometry.from_section(scene.geometry)
    on_root(comm, "creating the output folder", out.mkdir, parents=True, exist_ok=True)
    on_root(comm, f"writing {out / 'holding.json'}", write_json, out / "holding.json", record)
    text = markdown(record, geometry, scene_name)
    on_root(comm, f"writing {out / 'holding.md'}", write_text, out / "holding.md", text)
