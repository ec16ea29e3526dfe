"""What ``suture-fem run`` shows a person: pictures beside results.json and a short table of the answer.

The pictures (USUM on the mirrored section at the last reported force, and the force-displacement
curve) are drawn on rank 0 after the solve, from the model's state at its last reported force
(:meth:`suture_fem.model.Model.at`); a picture that cannot be drawn is a warning, never a lost results.json.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from suture_fem.geometry.regions import TISSUE_REGIONS

log = logging.getLogger("suture_fem")

USUM_PNG, CURVE_PNG, INTERFACE_PNG = "usum.png", "force_displacement.png", "interface.png"


class Pictures:
    """Captures the solved state at the last reported force (collective) and draws the pictures (rank 0)."""

    def __init__(self, out: Path, comm: Any):
        self.out, self.comm = out, comm
        self.grid: Any = None
        self.force_n: float | None = None

    def capture(self, model: Any) -> None:
        """Keep the model's state at the last reported force of its last solve (rank 0's grid; collective)."""
        from suture_fem import plots

        reports = model.results.at_forces if model.results is not None else []
        if reports:
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
        last = results["at_forces"][-1] if results["at_forces"] else {}
        if "interface" in last:
            from suture_fem.interface_plot import plot_interface

            drawings.append((INTERFACE_PNG, lambda png: plot_interface(last, png)))
        written = []
        for name, draw in drawings:
            if name == USUM_PNG and self.grid is None:
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
    return f"r = {rz[0]:.2f}, z = {rz[1]:.2f} mm"


def summary(results: Any, out: Path, written: list[Path]) -> str:
    """The answer in a few lines: per report force USUM and the tissue's SEQV and EPTOEQV, where each peaks."""
    lines = [f"suture-fem: {results['status']}; results in {out / 'results.json'}"]
    where = next((r.get("where", {}) for r in results["at_forces"]), {})
    if results["at_forces"]:
        measures = [f"USUM = {where.get('usum_mm', 'maximum over displacement nodes')}"]
        tissue = [name for name, key in (("SEQV", "seqv_pa"), ("EPTOEQV", "eptoeqv")) if key in where]
        if tissue:
            measures.append(f"tissue {' and '.join(tissue)} = {where.get('seqv_pa', where.get('eptoeqv'))} "
                            f"in the {', '.join(TISSUE_REGIONS)}")
        lines.append("  " + "; ".join(measures))
    model = results.get("effects", {}).get("interfaces")
    if model:
        lines.append(f"  interface: thread {model['thread']}, cones {model['cones']}")
    for rec in results["at_forces"]:
        cells = []
        if "usum_mm" in rec:
            cells.append(f"USUM {rec['usum_mm']:.4g} mm at {_at(rec['usum_mm_at_mm'])} ({rec['usum_mm_region']})")
        seqv = _tissue_peak(rec, "seqv_pa")
        if seqv is not None:
            cells.append(f"tissue SEQV {seqv[0] / 1e6:.4g} MPa at {_at(seqv[1])} ({seqv[2]})")
        strain = _tissue_peak(rec, "eptoeqv")
        if strain is not None:
            cells.append(f"tissue EPTOEQV {strain[0]:.4g} at {_at(strain[1])} ({strain[2]})")
        lines.append(f"  F = {rec['force_n']:g} N: " + "; ".join(cells))
        lines.append(f"      thread end {rec['thread_end_displacement_mm']:.4g} mm, reaction "
                     f"{rec['reaction_force_n']:.6g} N")
        if "load_share_n" in rec:
            shares = ", ".join(f"{name.replace('_', ' ')} {v:.3g}" for name, v in rec["load_share_n"].items())
            lines.append(f"      load passed to the tissue (N): {shares}")
    if "error_estimate" in results:
        lines.append(f"  {results['error_estimate'].get('usum_text', 'no error estimate')}")
    files = [out / "results.json", *written]
    files += [out / n for n in ("fields.xdmf", "fields.h5") if (out / n).exists()]
    lines.append("  written: " + ", ".join(str(f) for f in files))
    return "\n".join(lines)
