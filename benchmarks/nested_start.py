"""Benchmark (issue 14, a lever measured and not kept): start the P2 ramp from the P1 solution on the same mesh.

Solves the paper scene's 0-4 N ramp at P2 from rest, then, on the same mesh, the P1 ramp, whose state at
each report force (interpolated into P2) is handed to the P2 ramp as a warm start (``ramp(warm=)``, the
mechanism the calibration uses): the P2 steps then go straight to the report forces. Prints the Newton
iterations per step and the CPU seconds of each part, and writes JSON.

    .venv/bin/python benchmarks/nested_start.py [--set KEY=VALUE ...] [--out benchmarks/out/nested_start.json]

The question it answers: is the first step's cost (about 21 Newton iterations at P2, the line search
creeping at lambda ~ 0.1) a poor start, which a better global start (the P1 solution, or the issue's
1-D tube solution, a cruder one) would cure?
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    """Solve both ways, print, write."""
    from dolfinx import fem

    from suture_fem.geometry import mesh as meshmod
    from suture_fem.physics.problem import build_physics
    from suture_fem.pipeline import check, load_scene
    from suture_fem.solve.stepping import ramp
    from suture_fem.support.io import write_json

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/out/nested_start.json")
    args = parser.parse_args()
    scene = load_scene("paper", ["mesh.degree=2", *args.set])
    p1_scene = scene.with_values({"mesh.degree": 1})
    check(p1_scene)  # the P1 ramp must be a valid scene too (not with quadratic cells or the mixed formulation)
    tagged = meshmod.create_mesh(MPI.COMM_WORLD, scene.geometry, scene.mesh)
    rows, usum = {}, {}

    def solve(name, physics, s, warm=None, keep=None):
        def on_converged(force_n, report, **_):
            if report:  # USUM: the largest |u| over the displacement nodes of every rank (mm)
                u = physics.state.x.array.reshape(-1, 2)
                usum.setdefault(name, []).append(MPI.COMM_WORLD.allreduce(float(np.hypot(*u.T).max()), MPI.MAX) * 1e3)
                if keep is not None:
                    keep(force_n)
        t0 = time.process_time()
        result = ramp(physics, s, on_converged, warm=warm)
        # the forms each ramp compiles (or loads from the cache) the first time are not the lever measured
        rows[name] = {"steps": [[round(st.force_n, 4), st.iterations] for st in result.steps],
                      "newton_iterations": result.newton_iterations, "cutbacks": result.cutbacks,
                      "cpu_s": round(time.process_time() - t0 - result.timings.form_compilation, 2),
                      "form_compilation_s": round(result.timings.form_compilation, 2)}

    p2 = build_physics(tagged, scene)
    solve("P2 from rest", p2, scene)
    p1, states = build_physics(tagged, p1_scene), {}

    def keep(force_n):
        u = fem.Function(p2.state.function_space)
        u.interpolate(p1.state)
        states[round(force_n, 9)] = u.x.array.copy()

    solve("P1 from rest", p1, p1_scene, keep=keep)
    p2.state.x.array[:] = 0.0
    p2.sync()
    solve("P2 from the P1 states", p2, scene, warm=lambda f: states.get(round(f, 9)))
    if MPI.COMM_WORLD.rank == 0:
        print("| ramp | Newton its | steps (force N, its) | cutbacks | CPU (s, forms excluded) "
              "| USUM at the report forces (mm) |")
        print("| --- | ---: | --- | ---: | ---: | --- |")
        for name, r in rows.items():
            print(f"| {name} | {r['newton_iterations']} | {r['steps']} | {r['cutbacks']} | {r['cpu_s']} | "
                  + ", ".join(f"{v:.6f}" for v in usum[name]) + " |")
        write_json(args.out, {"scene_sets": args.set, "rows": rows, "usum_mm": usum})
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
