"""Experiment: a later answer of a Model started from the previous answer's states at the report forces.

    .venv/bin/python benchmarks/warm_answers.py [--scales 0.9,1.1] [--out benchmarks/out/warm_answers.json]

Solves the paper ramp (P1 r0) once; then, for each scale, solves the same Model again at that
``materials.tissue_scale`` from the previous answer's states (``model.solve(start="previous")``: each report
force's start state is the previous answer's) and a fresh Model from rest (what the command line computes),
and prints a table: Newton iterations and CPU of both, and the largest relative difference of results.json's
values (benchmarks/compare.py; the force-displacement curve, the solver's counts and the residuals aside: a
warm ramp steps straight to the report forces). docs/api.md, "A warm start for later answers";
benchmarks/many_answers.py ``--start previous`` puts it beside the command line.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import NOT_COMPARED, WARM_NOT_COMPARED, compare  # noqa: E402

import suture_fem as sf  # noqa: E402


def solve(model: sf.Model, out: Path, start: str) -> tuple[dict, float]:
    """Solve (from rest, or from the previous answer's states); results.json and the CPU seconds."""
    t0 = time.process_time()
    model.solve(out, start=start)
    return json.loads((out / "results.json").read_text()), time.process_time() - t0


def main() -> None:
    """Print the table and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scales", default="0.9,1.1")
    parser.add_argument("--out", default="benchmarks/out/warm_answers.json")
    args = parser.parse_args()
    base = sf.Scene.builtin("paper").with_values({"mesh.degree": 1})
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        model = sf.Model(base)
        solve(model, Path(tmp) / "first", "rest")
        for scale in (float(s) for s in args.scales.split(",")):
            model.set({"materials.tissue_scale": scale})
            warm, warm_cpu = solve(model, Path(tmp) / f"warm_{scale}", "previous")
            fresh, fresh_cpu = solve(sf.Model(base.with_values({"materials.tissue_scale": scale})),
                                     Path(tmp) / f"fresh_{scale}", "rest")
            skip = NOT_COMPARED | WARM_NOT_COMPARED
            found = compare(warm, fresh, skip)
            usum = max(abs(w["usum_mm"] / f["usum_mm"] - 1) for w, f in zip(warm["at_forces"], fresh["at_forces"]))
            rows.append({"scale": scale, "warm_newton": warm["newton_iterations"], "warm_cpu_s": warm_cpu,
                         "fresh_newton": fresh["newton_iterations"], "fresh_cpu_s": fresh_cpu,
                         "compared": found["compared"], "above_1e-10": found["above_1e-10"],
                         "largest": found["difference"], "largest_at": found["difference_at"],
                         "usum_largest": usum})
    print("| scale | Newton its warm / fresh | CPU s warm / fresh | values compared | above 1e-10 | largest (where) "
          "| USUM largest |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['scale']} | {r['warm_newton']} / {r['fresh_newton']} | {r['warm_cpu_s']:.2f} / "
              f"{r['fresh_cpu_s']:.2f} | {r['compared']} | {r['above_1e-10']} | {r['largest']:.1e} "
              f"({r['largest_at']}) | {r['usum_largest']:.1e} |")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({"rows": rows}, indent=1))


if __name__ == "__main__":
    main()
