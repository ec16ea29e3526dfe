"""Benchmark (issue 14): what one Newton iteration of the paper scene costs, part by part, against its factorisation.

The issue asks that a Newton iteration cost at most 1.2 times its factorisation. An iteration is at
least: the Jacobian's assembly (the element kernels and the insertion into the matrix), the reduction
T^T A T, the numeric factorisation, the triangular solves and one residual assembly (the line search's
trial; the energy too at degree 1, where it is the line search's merit). This script times each part on
the paper scene's mesh, in this process, on the solver's own matrices and MUMPS factorisation, and the
insertion alone: the same matrix assembled from a mass-like form (u . v r, the cheapest kernel with the
same sparsity). "Iteration" is the sum of the parts (at least one residual; the line search may take
more); "floor" is that iteration with a Jacobian kernel that cost nothing (the insertion, T^T A T, the
factorisation, the solves, the residual and energy), which no hyperelastic kernel can go below. Prints a
table and writes JSON.

    .venv/bin/python benchmarks/iteration_cost.py [--degrees 1,2] [--repeats 10] [--set KEY=VALUE ...]
        [--compile-args="-O3 -g0" --compile-args="-O3 -g0 -march=native" [--rounds 3]]
        [--out benchmarks/out/iteration_cost.json]

``--compile-args`` (repeatable) measures with the forms compiled with other C flags than the package's
(``compat.JIT_COMPILE_ARGS``), each set in turn, ``--rounds`` times round, so that flags can be
compared side by side in one process (each set compiles its own kernels: the cache key holds the flags).

The state is the rest state (the kernels cost the same at any state; the factorisation's pivoting may
differ slightly from a deformed state's). CPU seconds (``time.process_time``), the median of the repeats.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]


def _median_cpu(fn: Any, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


def measure(degree: int, sets: list[str], repeats: int, compile_args: tuple[str, ...]) -> dict[str, Any]:
    """The parts of one Newton iteration at ``degree`` on the paper scene, CPU seconds each."""
    import dolfinx.fem.petsc
    import ufl
    from mpi4py import MPI

    from suture_fem.geometry import mesh as meshmod
    from suture_fem.physics.forms import quadrature_degree
    from suture_fem.physics.problem import build_physics
    from suture_fem.pipeline import load_scene
    from suture_fem.solve.newton import NewtonSolver
    from suture_fem.solve.records import Timings
    from suture_fem.support import compat

    compat.JIT_COMPILE_ARGS = compile_args
    scene = load_scene("paper", [*sets, f"mesh.degree={degree}"])
    tagged = meshmod.create_mesh(MPI.COMM_WORLD, scene.geometry, scene.mesh)
    physics = build_physics(tagged, scene)
    newton = NewtonSolver(physics, scene.solver, Timings())
    u, v = ufl.TrialFunction(physics.W), ufl.TestFunction(physics.W)
    r = ufl.SpatialCoordinate(tagged.mesh)[0]
    mass = compat.form(ufl.inner(u, v) * r * ufl.dx(metadata={"quadrature_degree": quadrature_degree(degree)}))
    A_full, A, T = newton.A_full, newton.A, newton.reduction.T
    ksp = newton.snes.getKSP()
    ksp.setOperators(A)
    b, x = newton.b.duplicate(), newton.x.duplicate()
    b.set(1.0)

    jacobian = newton._assemble_full_jacobian  # the solver's own assembly of the full Jacobian

    def insertion() -> None:
        A_full.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A_full, mass)
        A_full.assemble()

    def reduction() -> None:
        A_full.ptap(T, A)

    def residual() -> None:
        newton._residual(newton.snes, newton.x, newton.b)

    def energy() -> None:
        newton._objective(newton.snes, newton.x)

    jacobian()
    reduction()
    ksp.getPC().setUp()  # the symbolic analysis, once
    fact_times = []
    for _ in range(repeats):
        reduction()  # a new matrix state, as after each Jacobian: the next set-up factorises it again
        t0 = time.process_time()
        ksp.getPC().setUp()
        fact_times.append(time.process_time() - t0)
    row = {
        "degree": degree,
        "compile_args": " ".join(compile_args),
        "dofs": int(physics.W.dofmap.index_map.size_global * physics.W.dofmap.index_map_bs),
        "jacobian_s": _median_cpu(jacobian, repeats),
        "insertion_floor_s": _median_cpu(insertion, repeats),
        "reduction_s": _median_cpu(reduction, repeats),
        "factorisation_s": statistics.median(fact_times),
    }
    jacobian()  # the solves and the residual at the Jacobian's factorisation (the insertion test overwrote A)
    reduction()
    ksp.getPC().setUp()
    row.update({
        "solve_s": _median_cpu(lambda: ksp.solve(b, x), repeats),
        "residual_s": _median_cpu(residual, repeats),
        "energy_s": _median_cpu(energy, repeats) if newton.objective_form is not None else 0.0,
        "pc": ksp.getPC().getType(),
        "solver": ksp.getPC().getFactorSolverType(),
    })
    fact, solve = row["factorisation_s"], row["solve_s"]
    assembly = row["jacobian_s"] + row["reduction_s"] + row["residual_s"] + row["energy_s"]
    # the "its factorisation", read narrowly (the numeric factorisation) and broadly (with the solves)
    row["iteration_over_factorisation"] = (assembly + fact + solve) / fact
    row["iteration_over_linear_solve"] = (assembly + fact + solve) / (fact + solve)
    floor = row["insertion_floor_s"] + row["reduction_s"] + row["residual_s"] + row["energy_s"] + fact + solve
    row["floor_over_factorisation"] = floor / fact
    row["floor_over_linear_solve"] = floor / (fact + solve)
    return row


def main() -> None:
    """Measure each degree, print the table, write the JSON."""
    from suture_fem.support.io import write_json

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--degrees", default="1,2")
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--compile-args", action="append", default=None, metavar="FLAGS",
                        help="C flags of the forms' kernels (repeatable; default: the package's own)")
    parser.add_argument("--rounds", type=int, default=1, help="times round the --compile-args sets")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/out/iteration_cost.json")
    args = parser.parse_args()
    from suture_fem.support import compat

    flag_sets = [tuple(f.split()) for f in args.compile_args] if args.compile_args else [compat.JIT_COMPILE_ARGS]
    load = os.getloadavg()[0]
    rows = [measure(int(d), args.set, args.repeats, flags) for _ in range(args.rounds) for flags in flag_sets
            for d in args.degrees.split(",")]
    ms = 1e3
    print(f"paper scene{' ' + ' '.join(args.set) if args.set else ''}, CPU ms (median of {args.repeats}), "
          f"load {load:.1f} / {os.getloadavg()[0]:.1f}")
    print("| compile args | degree | dofs | Jacobian | insertion floor | T^T A T | factorisation | solve | residual "
          "| energy | iteration / factorisation | iteration / (factorisation + solve) | floor / factorisation "
          "| floor / (factorisation + solve) |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r['compile_args']} | P{r['degree']} | {r['dofs']:,} | {r['jacobian_s'] * ms:.1f} | "
              f"{r['insertion_floor_s'] * ms:.1f} | "
              f"{r['reduction_s'] * ms:.1f} | {r['factorisation_s'] * ms:.1f} ({r['solver']} {r['pc']}) | "
              f"{r['solve_s'] * ms:.1f} | {r['residual_s'] * ms:.1f} | {r['energy_s'] * ms:.1f} | "
              f"{r['iteration_over_factorisation']:.2f} | {r['iteration_over_linear_solve']:.2f} | "
              f"{r['floor_over_factorisation']:.2f} | {r['floor_over_linear_solve']:.2f} |")
    write_json(args.out, {"scene_sets": args.set, "repeats": args.repeats, "rounds": args.rounds, "load_before": load,
                          "load_after": os.getloadavg()[0], "rows": rows})
    print(f"written: {args.out}")


if __name__ == "__main__":
    main()
