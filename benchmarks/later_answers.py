"""Later answers of one Model on two codes, side by side: CPU split, work counted, results.json compared.

    .venv/bin/python benchmarks/later_answers.py [--base main] [--rounds 2] [--scales 0.9,1.2,0.8]
        [--degree 1] [--out benchmarks/out/later_answers]

Each round runs the base commit's code (exported with ``git archive`` under /var/tmp, as
benchmarks/results_identity.py does) and then this tree, each in its own child process: the paper ramp
(refinement 0, ``--degree``) with :class:`suture_fem.Model`, a first answer, then one answer per scale after
``model.set({"materials.tissue_scale": s})``, every answer writing its results.json. For each later
answer the child reports its CPU seconds (``time.process_time``), split into Newton
(``NewtonSolver.solve``), outputs (``Outputs.evaluate`` and the thread end after every step) and the
rest, and counts its work: Jacobian, vector and scalar assemblies (dolfinx's C++ entry points), numeric and
symbolic factorisations (PETSc's log events), domain-guard checks, Newton iterations. Each answer's
results.json of this tree is compared with the base's (``wall_time_s``, ``timings_s`` and ``process``
apart): the same keys, every float equal bit for bit. Prints a table per code (the median over rounds
of each later answer's numbers) and the comparison; writes JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
COUNTED = ("assemble_matrix", "assemble_vector", "assemble_scalar", "guard_checks", "factor_numeric",
           "factor_symbolic")
PETSC_EVENTS = {"factor_numeric": ("MatCholFctrNum", "MatLUFactorNum"),
                "factor_symbolic": ("MatCholFctrSym", "MatLUFactorSym")}


def _petsc_counts(PETSc: Any) -> dict[str, int]:
    out = {}
    for name, events in PETSC_EVENTS.items():
        out[name] = sum(int(PETSc.Log.Event(e).getPerfInfo()["count"]) for e in events)
    return out


def child(degree: int, scales: list[float], out: Path) -> dict[str, Any]:
    """In this process: the first answer and one per scale; each later answer's CPU split and counts."""
    from petsc4py import PETSc

    PETSc.Log.begin()
    import dolfinx.cpp
    from mpi4py import MPI

    from suture_fem import Model, Scene
    from suture_fem.outputs.evaluate import Outputs
    from suture_fem.solve.guard import DomainGuard
    from suture_fem.solve.newton import NewtonSolver

    sys.path.insert(0, str(ROOT / "benchmarks"))  # the child runs with -P on another code's PYTHONPATH
    from meter import Meter

    meter = Meter()
    for owner, name in ((dolfinx.cpp.fem.petsc, "assemble_matrix"), (dolfinx.cpp.fem, "assemble_vector"),
                        (dolfinx.cpp.fem, "assemble_scalar")):
        meter.wrap(owner, name, name)
    meter.wrap(DomainGuard, "admissible", "guard_checks")
    meter.wrap(NewtonSolver, "solve", "newton")
    meter.wrap(Outputs, "evaluate", "outputs")
    meter.wrap(Outputs, "thread_end_displacement_mm", "outputs")
    model = Model(Scene.builtin("paper").with_values({"mesh.degree": degree, "mesh.refinement": 0}), MPI.COMM_SELF)
    model.solve(out / "answer_0")
    rows = []
    for i, scale in enumerate(scales, start=1):
        meter.take()
        petsc0 = _petsc_counts(PETSc)
        t0 = time.process_time()
        model.set({"materials.tissue_scale": scale})
        results = model.solve(out / f"answer_{i}").to_dict()
        total = time.process_time() - t0
        cpu, counts = meter.take()
        petsc1 = _petsc_counts(PETSc)
        row = {"answer": i, "tissue_scale": scale, "cpu_s": total, "newton_s": cpu.get("newton", 0.0),
               "outputs_s": cpu.get("outputs", 0.0), "newton_iterations": results["newton_iterations"],
               **{k: counts.get(k, 0) for k in COUNTED[:4]}, **{k: petsc1[k] - petsc0[k] for k in PETSC_EVENTS}}
        row["other_s"] = total - row["newton_s"] - row["outputs_s"]
        rows.append(row)
    return {"rows": rows, "suture_fem": __import__("suture_fem").__file__}


def run_child(code: Path, degree: int, scales: list[float], out: Path) -> dict[str, Any]:
    """:func:`child` in its own process on the package in ``code``."""
    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-P", str(Path(__file__).resolve()), "--child", "--degree", str(degree),
                           "--scales", ",".join(map(str, scales)), "--out", str(out)],
                          env=env, cwd=code, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{code}: the child exited {proc.returncode}: {proc.stderr[-3000:]}")
    record = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(record["suture_fem"]).is_relative_to(code), f"{code}: imported {record['suture_fem']}"
    return record


def compare(base: Path, now: Path, answers: int) -> dict[str, Any]:
    """Each answer's results.json of the two codes: the paths that differ, floats compared, largest difference."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from results_identity import NOT_COMPARED, differences

    out: dict[str, Any] = {"differing": [], "floats": 0, "largest_relative": 0.0}
    for i in range(answers + 1):
        a, b = (json.loads((p / f"answer_{i}" / "results.json").read_text()) for p in (base, now))
        for key in NOT_COMPARED:
            a.pop(key, None)
            b.pop(key, None)
        found, floats, worst = differences(a, b)
        out["differing"] += [f"answer {i}: {f}" for f in found]
        out["floats"] += floats
        out["largest_relative"] = max(out["largest_relative"], worst)
    return out


def table(name: str, runs: list[list[dict[str, Any]]]) -> str:
    """Per later answer, the median over rounds of each number (the rounds' range for the CPU)."""
    keys = ["cpu_s", "newton_s", "outputs_s", "other_s", "newton_iterations", *COUNTED]
    head = f"{name:>8} {'answer':>6} {'scale':>6} " + " ".join(f"{k[:15]:>15}" for k in keys) + "  CPU s (rounds)"
    lines = [head, "-" * len(head)]
    for j, row in enumerate(runs[0]):
        med = {k: statistics.median(run[j][k] for run in runs) for k in keys}
        spread = ", ".join(f"{run[j]['cpu_s']:.2f}" for run in runs)
        cells = " ".join(f"{med[k]:>15.3f}" if k.endswith("_s") else f"{med[k]:>15.0f}" for k in keys)
        lines.append(f"{name:>8} {row['answer']:>6} {row['tissue_scale']:>6.3f} {cells}  {spread}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main", help="the commit to compare with (default main)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--scales", default="0.9,1.2,0.8", help="tissue scales of the later answers")
    parser.add_argument("--degree", type=int, default=1)
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "later_answers"))
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    scales = [float(s) for s in args.scales.split(",")]
    out = Path(args.out).resolve()  # the children run in their code's folder
    if args.child:
        print(json.dumps(child(args.degree, scales, out)))
        return 0
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from results_identity import export

    codes = {"base": export(args.base), "this": ROOT}
    runs: dict[str, list[list[dict[str, Any]]]] = {name: [] for name in codes}
    loads = [os.getloadavg()[0]]
    for r in range(args.rounds):
        for name, code in codes.items():
            runs[name].append(run_child(code, args.degree, scales, out / f"{name}_{r}")["rows"])
            loads.append(os.getloadavg()[0])
    same = compare(out / "base_0", out / "this_0", len(scales))
    for name in codes:
        print(table(name, runs[name]))
    print(f"results.json, base against this tree, {len(scales) + 1} answers: {same['floats']} floats compared, "
          f"{len(same['differing'])} differences, largest relative {same['largest_relative']:.1e}")
    for line in same["differing"][:20]:
        print("  " + line)
    print(f"load (1 min) during the runs: {min(loads):.1f}-{max(loads):.1f}")
    record = {"base": args.base, "degree": args.degree, "scales": scales, "runs": runs, "identity": same,
              "load": loads}
    (out / "later_answers.json").write_text(json.dumps(record, indent=2) + "\n")
    return 0 if not same["differing"] else 1


if __name__ == "__main__":
    sys.exit(main())
