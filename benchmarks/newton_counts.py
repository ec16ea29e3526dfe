"""Benchmark: Newton iterations per 0-4 N ramp of the paper scene at every cone count, before and after.

Runs ``suture-fem run paper`` for 1-4 cones at degree 1 and 2 (USUM only, no pictures) with the
commit ``--before`` (a git worktree, as benchmarks/speed.py makes) and with this tree, one child
process each, side by side in one invocation. Prints a table and writes JSON: Newton iterations,
load steps and cutbacks per ramp, CPU seconds, USUM at 4 N and its relative change.

    .venv/bin/python benchmarks/newton_counts.py [--before COMMIT] [--degrees 1,2] [--cones 1,2,3,4]
        [--out benchmarks/out/newton_counts]

The counts do not depend on the machine's load; the CPU seconds do a little (compare them side by side).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from speed import ROOT, run, worktree  # noqa: E402


def case(code: Path, cones: int, degree: int, out: Path) -> dict:
    """One ramp of ``code``: its counts, CPU and USUM at the peak."""
    args = ["run", "paper", "--set", f"geometry.cones={cones}", "--set", f"mesh.degree={degree}",
            "--set", 'output.quantities=["usum"]', "--no-pictures"]
    row = run(code, args, out)
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else {}
    return {"cones": cones, "degree": degree, "exit": row["exit"], "cpu_s": row["cpu_s"],
            "newton_iterations": res.get("newton_iterations"), "load_steps": res.get("load_steps"),
            "cutbacks": res.get("cutbacks"), "usum_mm": res.get("usum_mm"), "load": row["load_before"]}


def main(argv: list[str] | None = None) -> int:
    """Run the cases with both codes, print the table, write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", default="3cc9886", help="the commit to compare with (default: 3cc9886, the "
                    "last commit before the tangent predictor)")
    ap.add_argument("--degrees", default="1,2")
    ap.add_argument("--cones", default="1,2,3,4")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "newton_counts"))
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    before = worktree(a.before)
    rows = []
    for degree in [int(d) for d in a.degrees.split(",")]:
        for cones in [int(c) for c in a.cones.split(",")]:
            pair = {}
            for label, code in (("before", before), ("now", ROOT)):
                pair[label] = case(code, cones, degree, out / f"{label}-p{degree}-c{cones}")
            b, n = pair["before"], pair["now"]
            change = (n["usum_mm"] / b["usum_mm"] - 1.0) if b["usum_mm"] and n["usum_mm"] else None
            rows.append({"cones": cones, "degree": degree, "before": b, "now": n, "usum_change_rel": change})
            print(f"{cones} cones P{degree}: Newton its {b['newton_iterations']} -> {n['newton_iterations']} (steps "
                  f"{b['load_steps']} -> {n['load_steps']}, cutbacks {b['cutbacks']} -> {n['cutbacks']}), CPU s "
                  f"{b['cpu_s']:.1f} -> {n['cpu_s']:.1f}, USUM change {change}", flush=True)
    head = ("| cones | element | Newton its before | Newton its now | CPU s before | CPU s now | USUM before (mm) | "
            "USUM now (mm) | USUM change |\n" + "| --- " * 9 + "|")
    print(head)
    for r in rows:
        b, n = r["before"], r["now"]
        print(f"| {r['cones']} | P{r['degree']} | {b['newton_iterations']} | {n['newton_iterations']} | "
              f"{b['cpu_s']:.1f} | {n['cpu_s']:.1f} | {b['usum_mm']} | {n['usum_mm']} | "
              f"{r['usum_change_rel'] if r['usum_change_rel'] is None else format(r['usum_change_rel'], '.1e')} |")
    (out / "newton_counts.json").write_text(json.dumps({"before": a.before, "rows": rows}, indent=2) + "\n")
    print(f"wrote {out / 'newton_counts.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
