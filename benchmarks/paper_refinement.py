"""Benchmark: the paper scene (4 hollow cones, 4 N, degree 2) at two mesh refinements.

Prints a table and writes JSON: dofs, load steps, Newton iterations, and the time split between
meshing, form compilation, assembly and linear solves. Each rung runs in its own process.

    .venv/bin/python benchmarks/paper_refinement.py [--refinements 0 1] [--out benchmarks/out/paper_refinement.json]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.support.io import write_json  # noqa: E402


def run(refinement: int, extra: list[str]) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", "--set", f"mesh.refinement={refinement}",
               "--out", tmp, *extra]
        proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
        if proc.returncode != 0:
            raise SystemExit(f"refinement {refinement} failed:\n{proc.stderr}")
        return json.loads((Path(tmp) / "results.json").read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--refinements", type=int, nargs="+", default=[0, 1])
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/paper_refinement.json"))
    args = ap.parse_args()
    extra = [a for o in args.overrides for a in ("--set", o)]
    rows = []
    for k in args.refinements:
        r = run(k, extra)
        t = r["timings_s"]
        rows.append({
            "refinement": k, "dofs": r["dofs"], "cells": r["cells"], "load_steps": r["load_steps"],
            "newton_iterations": r["newton_iterations"], "wall_time_s": round(r["wall_time_s"], 2),
            "meshing_s": t["meshing"], "form_compilation_s": t["form_compilation"], "assembly_s": t["assembly"],
            "linear_solve_s": t["linear_solve"], "guard_s": t["guard"],
            "usum_mm_at_1_2_3_4_n": [round(a["usum_mm"], 4) for a in r["at_forces"]],
            "eptoeqv_at_1_2_3_4_n": [round(a["eptoeqv"], 4) for a in r["at_forces"]],
            "tissue_seqv_pa_at_1_2_3_4_n": [round(a["regions"]["tissue"]["seqv_pa"]) for a in r["at_forces"]],
        })
    cols = ["refinement", "dofs", "cells", "load_steps", "newton_iterations", "wall_time_s", "meshing_s",
            "form_compilation_s", "assembly_s", "linear_solve_s"]
    print(" | ".join(cols))
    for row in rows:
        print(" | ".join(str(row[c]) for c in cols))
    for row in rows:
        print(f"refinement {row['refinement']}: USUM {row['usum_mm_at_1_2_3_4_n']} mm, "
              f"EPTOEQV {row['eptoeqv_at_1_2_3_4_n']}, tissue SEQV {row['tissue_seqv_pa_at_1_2_3_4_n']} Pa")
    write_json(args.out, {"scene": "paper", "overrides": args.overrides, "rows": rows})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
