"""The summary: one row per scene, read from the folders, written as ``OUT/summary.{json,csv,md}``.

World rank 0 writes it at the end of a run (``--summary-only`` rebuilds it without solving), with
``OUT/last_run.json``: what this run solved and skipped.
"""

from __future__ import annotations

import csv
import io
from typing import Any

from suture_fem.studies.sweep.folders import read_status
from suture_fem.studies.sweep.plan import Sweep, toml_value
from suture_fem.support.io import read_json, write_json, write_text

#: Summary columns taken from results.json (dotted paths), after the varied keys.
RESULT_COLUMNS = (
    "usum_mm", "regions.tissue.seqv_pa", "regions.tissue.eptoeqv", "seqv_pa", "eptoeqv", "seqv_outside_rim_pa",
    "force_reached_n", "thread_end_displacement_mm", "reaction_force_n", "load_steps", "newton_iterations",
    "cutbacks", "dofs",
)
STATUS_COLUMNS = ("ranks", "wall_time_s", "solve_count", "message")


def _dig(data: dict[str, Any] | None, dotted: str) -> Any:
    node: Any = data
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def summary_rows(sweep: Sweep) -> list[dict[str, Any]]:
    """One row per case, read from its folder ("pending" where there is none yet)."""
    rows = []
    for case in sweep.cases:
        folder = sweep.out / case.name
        status = read_status(folder)
        try:
            results = read_json(folder / "results.json")
        except (OSError, ValueError):
            results = None
        row: dict[str, Any] = {"index": case.index, "name": case.name,
                               "status": status["status"] if status else "pending"}
        row.update({key: case.varied.get(key) for key in sweep.varied_keys})
        row.update({col: _dig(results, col) for col in RESULT_COLUMNS})
        row.update({col: (status or {}).get(col) for col in STATUS_COLUMNS})
        rows.append(row)
    return rows


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, dict, bool)):
        return toml_value(value)
    return str(value)


#: First characters that make a spreadsheet read a cell as a formula (or a command).
FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r", "|", "%")


def csv_cell(value: Any) -> str:
    """A summary value as a CSV cell; text a spreadsheet would run as a formula gets a leading ``'``.

    Numbers (``-1.5``, ``+2e-3``) stay numbers; any other cell beginning with ``= + - @ | %``, a tab or
    a carriage return is written as ``'=...``, which spreadsheets show as text.
    """
    text = _cell(value)
    if text.startswith(FORMULA_STARTS):
        try:
            float(text)
        except ValueError:
            return "'" + text
    return text


def write_summary(sweep: Sweep, last_run: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write OUT/summary.{json,csv,md} from the scene folders (and OUT/last_run.json); returns the JSON."""
    rows = summary_rows(sweep)
    columns = list(rows[0]) if rows else []
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    data = {"sweep": str(sweep.path), "base": sweep.base, "out": str(sweep.out), "scenes": len(rows),
            "counts": counts, "columns": columns, "rows": rows}
    write_json(sweep.out / "summary.json", data)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([csv_cell(c) for c in columns])
    writer.writerows([csv_cell(row[c]) for c in columns] for row in rows)
    write_text(sweep.out / "summary.csv", buf.getvalue())
    md = [f"# Sweep {sweep.path.name}: {len(rows)} scenes of {sweep.base}", "",
          ", ".join(f"{n} {s}" for s, n in sorted(counts.items())), "",
          "| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    md += ["| " + " | ".join(_cell(row[c]).replace("|", "\\|").replace("\n", " ") for c in columns) + " |"
           for row in rows]
    write_text(sweep.out / "summary.md", "\n".join(md) + "\n")
    if last_run is not None:
        write_json(sweep.out / "last_run.json", last_run)
    return data
