"""Experiment: a later answer of a Model started from the previous answer's states at the report forces.

    .venv/bin/python benchmarks/warm_answers.py [--scales 0.9,1.1] [--out benchmarks/out/warm_answers.json]

Solves the paper ramp (P1 r0) once; then, for each scale, solves the same Model again at that
``materials.tissue_scale`` from the previous answer's states (``model.solve(start="previous")``: each report
force's start state is the previous answer's) and a fresh Model from rest (what the command line computes),
and prints a table: Newton iterations and CPU of both, and the largest relative difference of results.json's
floats (the force-displacement curve and the solver's counts aside: a warm ramp steps straight to the report
forces). docs/api.md, "A warm start for later answers"; benchmarks/many_answers.py ``--start previous`` puts
it beside the command line.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import suture_fem as sf

#: results.json keys (any part of the path) not compared: timings, counts, the curve's points, the residuals.
NOT_COMPARED = ("timings", "wall_time", "process", "newton_iterations", "load_steps", "steps", "cutbacks",
                "residual_floor", "free_residual", "solves_at", "force_balance", "force_displacement",
                "inertia_shifts", "domain_rejections", "line_search", "fallbacks", "linear_solver")


def flat(x: object, pre: str = "") -> dict[str, float]:
    """Every number of a JSON tree by its path."""
    out: dict[str, float] = {}
    if isinstance(x, dict):
        for k, v in x.items():
            out.update(flat(v, f"{pre}.{k}"))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            out.update(flat(v, f"{pre}[{i}]"))
    elif isinstance(x, (int, float)) and not isinstance(x, bool):
        out[pre] = float(x)
    return out


def differences(a: dict, b: dict) -> list[tuple[float, str]]:
    """(relative difference, path) of the compared floats, largest first."""
    fa, fb = flat(a), flat(b)
    rows = []
    for key in fa.keys() & fb.keys():
        if not any(s in key for s in NOT_COMPARED):
            d = abs(fa[key] - fb[key]) / abs(fb[key]) if fb[key] != 0 else abs(fa[key])
            rows.append((d, key))
    return sorted(rows, reverse=True)


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
            diffs = differences(warm, fresh)
            usum = max(abs(w["usum_mm"] / f["usum_mm"] - 1) for w, f in zip(warm["at_forces"], fresh["at_forces"]))
            rows.append({"scale": scale, "warm_newton": warm["newton_iterations"], "warm_cpu_s": warm_cpu,
                         "fresh_newton": fresh["newton_iterations"], "fresh_cpu_s": fresh_cpu,
                         "compared": len(diffs), "above_1e-10": sum(d > 1e-10 for d, _ in diffs),
                         "largest": diffs[0][0], "largest_at": diffs[0][1], "usum_largest": usum})
    print("| scale | Newton its warm / fresh | CPU s warm / fresh | floats compared | above 1e-10 | largest (where) "
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
