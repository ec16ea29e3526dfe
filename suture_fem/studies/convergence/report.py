"""The ledger's files: ``ledger.json``, ``ledger.md`` (tables) and ``ledger.png``.

``ledger.png`` plots relative error against wall time, log-log, one curve per quantity and degree;
``ledger-cpu.png`` the same against CPU time, which a busy machine does not inflate.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

from suture_fem.studies.convergence.analysis import within
from suture_fem.studies.convergence.ladder import Ladder, Rung, ladder_key
from suture_fem.studies.convergence.quantities import REFINEMENT_RATIO, fmt_value
from suture_fem.support.io import save_figure, write_json, write_text


def _num(v: float | None, digits: int = 1) -> str:
    return "-" if v is None else f"{v:.{digits}f}"


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.2g} %"


def markdown(title: str, ladder: Ladder, rungs: list[Rung], analysis: dict[str, Any], tol: float = 0.01) -> str:
    """The ledger as markdown: the cost of every rung, then per force its values, errors and verdicts."""
    lines = [f"# Accuracy-cost ledger: {title}", ""]
    with_overrides = " with " + ", ".join(f"`{o}`" for o in ladder.overrides) if ladder.overrides else ""
    lines += [
        f"Scene `{ladder.source}`" + with_overrides
        + f"; degrees {ladder.degrees}, "
        + _levels(ladder),
        "",
    ]
    lines += _cost_table(rungs)
    for fk, per_q in analysis.items():
        lines += _force_section(fk, per_q, rungs, analysis, tol)
    return "\n".join(lines)


def _levels(ladder: Ladder) -> str:
    """What the ladder's levels refine, in words."""
    if ladder.refine == "fillet":
        cells = ("quadratic cells, their mid-side nodes on the arcs (mesh.geometry_degree = 2)"
                 if ladder.base_mesh.geometry_degree == 2 else
                 "straight-sided cells: each arc is a polygon (mesh.geometry_degree = 2 puts the cells on the arc)")
        return (f"fillet levels {ladder.refinements} (only mesh.fillet_elements doubles per level: the elements "
                f"along each rounded rim's arc; the rest of the mesh stays at the scene's mesh.refinement); {cells}.")
    if ladder.refine == "rim":
        return f"rim levels {ladder.refinements} (only mesh.size_rim_mm halves per level, at the cone corners)."
    return f"refinements {ladder.refinements} (every element size halves per step)."


def _cost_table(rungs: list[Rung]) -> list[str]:
    """The table of what each rung cost, with what its columns measure."""
    lines = [
        "## Cost of each rung",
        "",
        "| rung | cells | dofs | wall time (s) | CPU time (s) | process (s) | forms (s) | peak memory (MB) "
        "| Newton its | load steps | load average | status |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |",
    ]
    for r in rungs:
        load = "-" if not r.load_average else " / ".join(f"{v:.1f}" for v in r.load_average)
        lines.append(
            f"| {r.label} | {r.cells or '-'} | {r.dofs or '-'} | {_num(r.wall_time_s)} | {_num(r.cpu_time_s)} | "
            f"{_num(r.process_time_s)} | {_num(r.compile_time_s, 2)} | {_num(r.peak_memory_mb, 0)} | "
            f"{r.newton_iterations or '-'} | "
            f"{r.load_steps or '-'} | {load} | {r.status} |"
        )
    notes = sorted({r.memory_note for r in rungs if r.memory_note})
    lines += ["", "Wall time: inside `run` (meshing, forms, load ramp, outputs); CPU time and process time: the whole "
              "command; forms: the part of the wall time spent compiling forms (near 0: they came from the disk "
              "cache, so no rung pays for another's); load average: the machine's 1-minute load before and after "
              "the rung (above the core count, other work was slowing the wall time). Memory: "
              + ("; ".join(notes) or "-") + ".", ""]
    return lines


def _force_section(fk: str, per_q: dict[str, Any], rungs: list[Rung], analysis: dict[str, Any],
                   tol: float) -> list[str]:
    """At one force: every rung's values and errors, the reference, the estimates per ladder and the verdicts."""
    lines = [f"## At {fk} N: value (error against the reference)", ""]
    header = "| rung | " + " | ".join(p["label"] for p in per_q.values()) + " |"
    lines += [header, "| --- |" + " ---: |" * len(per_q)]
    for r in rungs:
        cells = []
        for p in per_q.values():
            e = p["rungs"].get(r.name, {})
            cells.append(f"{fmt_value(e.get('value'), p['unit'])} ({_pct(e.get('error_rel'))})")
        lines.append(f"| {r.label} | " + " | ".join(cells) + " |")
    ref_cells = []
    for p in per_q.values():
        ref = p["reference"]
        ref_cells.append(f"{fmt_value(ref['value'], p['unit'])} (from {ref['from']}, +- "
                         f"{_pct(abs(ref['correction'] / ref['value']))})" if ref else "no limit")
    lines.append("| **reference** (+- its Richardson correction) | " + " | ".join(ref_cells) + " |")
    lines += ["", "| quantity | ladder | rungs | observed order | extrapolated | change per refinement | verdict |",
              "| --- | --- | --- | ---: | ---: | --- | --- |"]
    lv = rungs[0].level_name if rungs else "r"  # r, rim or fillet: what the levels refine
    for p in per_q.values():
        for key, e in p["estimates"].items():
            changes = ", ".join(_pct(c) for c in e["changes_rel"])
            order = f"{e['order']:.2f}" if e["order"] is not None else "-"
            lines.append(f"| {p['label']} | {key} | {lv}{e['refinements'][0] if e['refinements'] else '-'}"
                         f"-{lv}{e['refinements'][-1] if e['refinements'] else '-'} | {order} | "
                         f"{fmt_value(e['limit'], p['unit'])} | {changes} | {e['verdict']} |")
    lines += ["", "Verdicts: " + "; ".join(f"{p['label']}: {p['verdict']}" for p in per_q.values()) + ".", ""]
    return lines + _usum_cost(fk, rungs, analysis, tol) + _two_rung_checks(per_q, rungs)


def _usum_cost(fk: str, rungs: list[Rung], analysis: dict[str, Any], tol: float) -> list[str]:
    """Per ladder, the coarsest rung whose USUM is within ``tol`` of the reference, and its cost."""
    usum = within(analysis, rungs, float(fk), "usum_mm", tol)
    if not usum:
        return []
    level = "refinement " if not rungs or rungs[0].level_name == "r" else rungs[0].level_name  # fillet3, rim1
    return [f"USUM within {100 * tol:g} % of the reference: " + "; ".join(
        f"{k} from {level}{v['refinement']} ({_num(v['wall_time_s'])} s wall, {_num(v['cpu_time_s'])} s CPU, "
        f"{v['dofs']} dofs, "
        f"error {_pct(v['error_rel'])})" for k, v in usum.items()) + ".", ""]


def _two_rung_checks(per_q: dict[str, Any], rungs: list[Rung]) -> list[str]:
    """Whether `run --error-estimate`'s two-rung estimate of USUM covers the error the ledger measures."""
    if any(r.level_name != "r" for r in rungs):  # the estimate is of a global refinement, not a local one
        return []
    checks = [(r, per_q["usum_mm"]["rungs"].get(r.name, {})) for r in rungs]
    checks = [(r, e) for r, e in checks if e.get("two_rung_estimate_rel") is not None and "error_rel" in e]
    if not checks:
        return []
    lines = ["`run --error-estimate` (order 1 assumed: +- |USUM_h - USUM_2h|) against the error measured "
             "here:", "", "| rung | +- (two rungs) | error against the reference | covered |",
             "| --- | ---: | ---: | --- |"]
    lines += [f"| {r.label} | {_pct(e['two_rung_estimate_rel'])} | {_pct(e['error_rel'])} | "
              f"{'yes' if e['two_rung_estimate_rel'] >= e['error_rel'] else 'no'} |" for r, e in checks]
    return lines + [""]


#: What the ledger's plot puts on its time axis (``--time``).
TIME_AXES = {"wall": ("wall_time_s", "wall time per solve (s)"),
             "cpu": ("cpu_time_s", "CPU time per solve (s): the wall time on an otherwise idle core")}


def _draw_force(ax: Any, per_q: dict[str, Any], by_name: dict[str, Rung], time_key: str, colors: list[str]) -> None:
    """One panel: every quantity's curve per ladder, each point labelled with its refinement."""
    markers = {1: "o", 2: "s"}
    for qi, p in enumerate(per_q.values()):
        color = colors[qi % len(colors)]
        for key in p["estimates"]:
            seq = [by_name[n] for n in p["rungs"] if n in by_name and ladder_key(by_name[n]) == key]
            seq.sort(key=lambda r: r.refinement)
            if p["reference"] is not None:
                pts = [(getattr(r, time_key), p["rungs"][r.name].get("error_rel"), r.refinement) for r in seq]
                style, suffix = "-", ""
            else:
                changes = p["estimates"][key]["changes_rel"]
                pts = [(getattr(r, time_key), c, r.refinement) for r, c in zip(seq[1:], changes)]
                style, suffix = "--", " (no limit: change per refinement)"
            pts = [(t, e, k) for t, e, k in pts if t and e]
            if not pts:
                continue
            degree = seq[0].degree
            ax.plot([t for t, _, _ in pts], [e for _, e, _ in pts], style, color=color,
                    marker=markers.get(degree, "^"), alpha=1.0 if degree == 1 else 0.7,
                    label=f"{p['label']}, {key}{suffix}")
            for t, e, k in pts:
                ax.annotate(f"{seq[0].level_name}{k}", (t, e), textcoords="offset points", xytext=(3, 3),
                            fontsize=7, color=color)


def plot(path: Path, title: str, rungs: list[Rung], analysis: dict[str, Any], time_axis: str = "wall") -> None:
    """Relative error against time per solve, log-log: one curve per quantity and ladder, one panel per force.

    Quantities without a limit are drawn dashed as their relative change per refinement.
    """
    time_key, xlabel = TIME_AXES[time_axis]
    from matplotlib import rcParams

    from suture_fem.plots import file_figure  # no pyplot: a notebook's backend is left alone

    forces = list(analysis)
    n_curves = sum(len(p["estimates"]) for p in next(iter(analysis.values()), {}).values())
    legend_rows = math.ceil(n_curves / 2)
    height = 5.0 + 0.2 * legend_rows
    fig = file_figure(figsize=(max(12.0, 6.5 * len(forces)), height))
    axes = fig.subplots(1, len(forces), squeeze=False)
    by_name = {r.name: r for r in rungs}
    colors = rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, fk in zip(axes[0], forces):
        _draw_force(ax, analysis[fk], by_name, time_key, colors)
        ax.axhline(0.01, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("relative error (solid), change per refinement (dashed)")
        ax.set_title(f"{title}: {fk} N")
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, (0.2 * legend_rows + 0.3) / height, 1, 1))
    save_figure(fig, path, dpi=130)


def write_ledger(out: Path, title: str, ladder: Ladder, rungs: list[Rung], analysis: dict[str, Any]) -> dict[str, Any]:
    """Write ledger.json, ledger.md and ledger.png into ``out`` (call on one rank)."""
    from suture_fem import __version__
    from suture_fem.support import compat

    record = {
        "title": title,
        "suture_fem_version": __version__,
        "dolfinx_version": compat.DOLFINX_VERSION,
        "ladder": asdict(ladder),
        "refinement_ratio": REFINEMENT_RATIO,
        "rungs": [asdict(r) for r in rungs],
        "analysis": analysis,
        "usum_within_1_percent": {fk: within(analysis, rungs, float(fk), "usum_mm", 0.01) for fk in analysis},
    }
    write_json(out / "ledger.json", record)
    write_text(out / "ledger.md", markdown(title, ladder, rungs, analysis))
    plot(out / "ledger.png", title, rungs, analysis, "wall")
    if all(r.cpu_time_s for r in rungs if r.status == "converged"):
        plot(out / "ledger-cpu.png", title, rungs, analysis, "cpu")
    return record
