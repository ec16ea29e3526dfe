"""What ``suture-fem run`` shows a person: pictures beside results.json and a short table of the answer.

The pictures (USUM on the mirrored section at the last reported force, or the slab's skin and its cut through
the thread, and the force-displacement curve) are drawn on rank 0 after the solve, from the model's state at its
last reported force (:meth:`suture_fem.model.Model.at`); a picture that cannot be drawn is a warning, never a lost
results.json.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from suture_fem.geometry.regions import TISSUE_REGIONS, WHOLE_TISSUE

log = logging.getLogger("suture_fem")

USUM_PNG, CURVE_PNG, INTERFACE_PNG = "usum.png", "force_displacement.png", "interface.png"
#: The slab's pictures (3-D, ``geometry.tissue_shape = "slab"``; :mod:`suture_fem.plots_slab`).
SKIN_PNG, CUT_PNG = "skin.png", "cut.png"


class Pictures:
    """Captures the solved state at the last reported force (collective) and draws the pictures (rank 0)."""

    def __init__(self, out: Path, comm: Any):
        self.out, self.comm = out, comm
        self.grid: Any = None
        self.force_n: float | None = None
        self.slab = False

    def capture(self, model: Any) -> None:
        """Keep the model's state at the last reported force of its last solve (rank 0's grid; collective)."""
        from suture_fem import plots

        reports = model.results.at_forces if model.results is not None else []
        self.slab = model.mesh.geometry.dim == 3 and model.scene.geometry.tissue_shape == "slab"
        # the USUM picture is of the 2-D section, the skin and the cut of the slab (the 3-D cylinder: the curve only)
        if reports and (model.mesh.geometry.dim == 2 or self.slab):
            with model.at(reports[-1].force_n) as report:
                self.grid, self.force_n = plots.field_grid(model.outputs), report.force_n

    def draw(self, results: Any, scene_name: str) -> list[Path]:
        """Draw both pictures (rank 0); returns the paths written. Failures are logged, not raised."""
        if self.comm.rank != 0:
            return []
        from suture_fem import plots

        _quiet_vtk()
        drawings = [(USUM_PNG, lambda png: plots.render_usum(
                        [self.grid], png, titles=[f"{scene_name}: USUM at F = {self.force_n:g} N"])),
                    (CURVE_PNG, lambda png: plots.plot_force_displacement(
                        {scene_name: results["force_displacement"]}, png))]
        if self.slab:
            from suture_fem import plots_slab

            at = f"{scene_name}, F = {self.force_n:g} N"
            drawings = [(SKIN_PNG, lambda png: plots_slab.render_skin(
                            self.grid, png, f"{at}: skin surface, displacement along the outward normal")),
                        (CUT_PNG, lambda png: plots_slab.render_cut(
                            self.grid, png, f"{at}: cut through the thread (z = 0), tissue von Mises stress")),
                        drawings[1]]
        last = results["at_forces"][-1] if results["at_forces"] else {}
        if "interface" in last:
            from suture_fem.interface_plot import plot_interface

            drawings.append((INTERFACE_PNG, lambda png: plot_interface(last, png)))
        written = []
        for name, draw in drawings:
            if name in (USUM_PNG, SKIN_PNG, CUT_PNG) and self.grid is None:
                continue
            try:
                written.append(draw(self.out / name))
            except Exception as exc:  # noqa: BLE001 (a picture must never cost the results)
                log.warning("%s could not be drawn (%s: %s); results.json is complete", name,
                            type(exc).__name__, exc)
        return written


def _quiet_vtk() -> None:
    """VTK's own log (e.g. "bad X server connection" of an off-screen render) stays off the terminal."""
    try:
        from vtkmodules.vtkCommonCore import vtkLogger
    except ImportError:
        return
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)


def _tissue_peak(rec: dict[str, Any], key: str) -> tuple[float, list[float], str] | None:
    """The largest value of ``key`` over the tissue regions: (value, (r, z) mm, region)."""
    regions = rec.get("regions", {})
    found = [(regions[r][key], regions[r][f"{key}_at_mm"], r) for r in TISSUE_REGIONS
             if key in regions.get(r, {})]
    return max(found, key=lambda t: t[0]) if found else None


def _at(rz: list[float]) -> str:
    if len(rz) == 3:  # 3-D: (x, y, z), the thread along y
        return f"x = {rz[0]:.2f}, y = {rz[1]:.2f}, z = {rz[2]:.2f} mm"
    return f"r = {rz[0]:.2f}, z = {rz[1]:.2f} mm"


#: The converged tissue measures the summary leads with: (label, key in the tissue record, scale, unit).
CONVERGED = (("SEQV", "seqv_cd_pa", 1e-6, " MPa"), ("EPTOEQV", "eptoeqv_cd", 1.0, ""))


def _estimate(results: Any, force_n: float, key: str) -> float | None:
    """The estimated discretisation error of the tissue's ``key`` at ``force_n`` (``--error-estimate``), if any."""
    for entry in results.get("error_estimate", {}).get("at_forces", []):
        if abs(entry["force_n"] - force_n) <= 1e-9 * max(1.0, force_n):
            return (entry.get(f"regions.tissue.{key}") or {}).get("plus_minus")
    return None


def _converged_line(results: Any, rec: dict[str, Any]) -> str | None:
    """The tissue's critical-distance SEQV and EPTOEQV (each +- its estimated error where known), or None."""
    tissue = rec.get("regions", {}).get(WHOLE_TISSUE, {})
    cells = []
    for label, key, scale, unit in CONVERGED:
        if key not in tissue:
            continue
        pm = _estimate(results, rec["force_n"], key)
        error = f" +- {pm * scale:.2g}" if pm is not None else ""
        cells.append(f"{label} {tissue[key] * scale:.4g}{error}{unit} at {_at(tissue[f'{key}_at_mm'])}")
    if not cells:
        return None
    radius = results.get("scene", {}).get("output", {}).get("critical_distance_mm")
    return f"tissue, critical distance {radius:g} mm: " + "; ".join(cells)


def _peak_line(rec: dict[str, Any]) -> str | None:
    """The tissue's raw SEQV and EPTOEQV peaks, marked mesh-dependent, or None."""
    cells = []
    for label, key, scale, unit in (("SEQV", "seqv_pa", 1e-6, " MPa"), ("EPTOEQV", "eptoeqv", 1.0, "")):
        peak = _tissue_peak(rec, key)
        if peak is not None:
            cells.append(f"{label} {peak[0] * scale:.4g}{unit} at {_at(peak[1])} ({peak[2]})")
    return ("tissue peak, maximum over quadrature points (mesh-dependent; singular at a sharp rim): " + "; ".join(cells)
            if cells else None)


def _measures(results: Any) -> str:
    """The header line: what USUM and the tissue measures are."""
    where = next((r.get("where", {}) for r in results["at_forces"]), {})
    measures = [f"USUM = {where.get('usum_mm', 'maximum over displacement nodes')}"]
    if "seqv_cd_pa" in where:
        radius = results.get("scene", {}).get("output", {}).get("critical_distance_mm")
        bars = "" if "error_estimate" in results else "; error bars: run with --error-estimate"
        shape = "ball" if "model_3d" in results else "disc"  # 3-D: the ball's average
        measures.append(f"tissue SEQV and EPTOEQV averaged over a {shape} of radius {radius:g} mm where largest "
                        f"(critical distance; converge under refinement{bars})")
    elif "seqv_pa" in where or "eptoeqv" in where:
        measures.append(f"tissue SEQV and EPTOEQV = {where.get('seqv_pa', where.get('eptoeqv'))} "
                        f"in the {', '.join(TISSUE_REGIONS)}")
    return "  " + "; ".join(measures)


def summary(results: Any, out: Path, written: list[Path]) -> str:
    """The answer in a few lines: per report force USUM, the tissue's converged measures, then its raw peaks.

    The critical-distance SEQV and EPTOEQV (with their estimated discretisation error after
    ``--error-estimate``) lead; the raw peaks follow one line below, marked mesh-dependent.
    """
    lines = [f"suture-fem: {results['status']}; results in {out / 'results.json'}"]
    if results["at_forces"]:
        lines.append(_measures(results))
    model = results.get("effects", {}).get("interfaces")
    if model:
        lines.append(f"  interface: thread {model['thread']}, cones {model['cones']}")
    for rec in results["at_forces"]:
        usum = (f"USUM {rec['usum_mm']:.4g} mm at {_at(rec['usum_mm_at_mm'])} ({rec['usum_mm_region']})"
                if "usum_mm" in rec else "")
        lines.append(f"  F = {rec['force_n']:g} N: {usum}".rstrip())
        lines += [f"      {line}" for line in (_converged_line(results, rec), _peak_line(rec)) if line]
        lines.append(f"      thread end {rec['thread_end_displacement_mm']:.4g} mm, reaction "
                     f"{rec['reaction_force_n']:.6g} N")
        if "load_share_n" in rec:
            shares = ", ".join(f"{name.replace('_', ' ')} {v:.3g}" for name, v in rec["load_share_n"].items())
            lines.append(f"      load passed to the tissue (N): {shares}")
        if "dimple_depth_mm" in rec:
            dimples = ", ".join(f"{v:.3g}" for v in rec["dimple_depth_mm"]) or "no cone"
            reliefs = ", ".join("-" if v is None else f"{v:.3g}" for v in rec.get("dimple_relief_mm", []))
            dimples += f" (under a straightedge: {reliefs})" if reliefs else ""
            lines.append(f"      skin (mm, along its outward normal): dimple over each cone {dimples}; largest inward "
                         f"{rec['skin_inward_mm']:.3g} at {_at(rec['skin_inward_at_mm'])}, largest outward "
                         f"{rec['skin_outward_mm']:.3g}")
    if "error_estimate" in results:
        lines.append(f"  {results['error_estimate'].get('usum_text', 'no error estimate')}")
    files = [out / "results.json", *written]
    files += [out / n for n in ("fields.xdmf", "fields.h5") if (out / n).exists()]
    lines.append("  written: " + ", ".join(str(f) for f in files))
    return "\n".join(lines)
