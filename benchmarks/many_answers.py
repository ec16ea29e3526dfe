"""Many answers from one Model: the paper ramp solved again after ``materials.tissue_scale`` changes.

    .venv/bin/python benchmarks/many_answers.py [--answers 10] [--no-write] [--out benchmarks/out/many_answers]

In one process: build the Model of the paper scene at P1, refinement 0 (4 cones, the ramp to 4 N with
reports at 1, 2, 3 N) and solve it (the first answer, its CPU counted from before ``import
suture_fem``), then ``model.set({"materials.tissue_scale": s})`` and solve again for ``--answers``
values of s. Each later answer's CPU is split into Newton (``NewtonSolver.solve``), outputs
(``Outputs.evaluate`` at the reported forces and the thread end after every step; the critical-distance
searches apart) and the rest; counters, installed before the package is imported, say what a later
answer did: modules imported (a ``sys.meta_path`` finder sees every import that is not already done),
meshes made (``geometry.mesh.scene_mesh``) and forms, expressions or elements loaded
(``dolfinx.jit.ffcx_jit``, the one door to FFCx's cache and compiler). Beside each answer, the same
answer from the command line in this run (``suture-fem run paper --set ... --no-pictures``, its own
process; CPU from the children's rusage), whose results.json must equal the in-process answer to 1e-10
(times and the process apart). The same work on both sides: each in-process answer writes its
results.json too (``model.solve(folder)``, rewritten after every step as the command line does; about
0.07 s of CPU per answer, counted in "other"); ``--no-write`` leaves it out. Prints a table and the
targets met or not; writes JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

T_START = time.process_time()
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
from compare import NOT_COMPARED, WARM_NOT_COMPARED, compare  # noqa: E402
from meter import Meter  # noqa: E402

SETS = {"mesh.degree": 1, "mesh.refinement": 0}
#: The yardstick for a warm answer: the command line's own answer along another load path (a first step of
#: 0.125 of the pull instead of 0.1), against its default one.
OTHER_PATH = {"solver.initial_step": 0.125}


class ImportCounter:
    """A ``sys.meta_path`` finder that counts the imports not already done (it finds nothing itself)."""

    def __init__(self) -> None:
        self.count = 0
        self.names: list[str] = []

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> None:
        self.count += 1
        self.names.append(name)


IMPORTS = ImportCounter()
sys.meta_path.insert(0, IMPORTS)


def install(meter: Meter) -> None:
    """Wrap the parts timed and counted (after the first import of the package: the first answer pays it)."""
    import dolfinx.jit

    from suture_fem.geometry import mesh as meshmod
    from suture_fem.outputs.critical_distance import CriticalDistance
    from suture_fem.outputs.evaluate import Outputs
    from suture_fem.solve.newton import NewtonSolver

    meter.wrap(dolfinx.jit, "ffcx_jit", "form_loading")
    meter.wrap(meshmod, "scene_mesh", "meshing")
    meter.wrap(NewtonSolver, "solve", "newton")
    meter.wrap(Outputs, "evaluate", "outputs")
    meter.wrap(Outputs, "thread_end_displacement_mm", "thread_end")
    meter.wrap(CriticalDistance, "_measure", "critical_distance")


def cli_answer(scale: float, out: Path, extra: dict[str, Any] | None = None) -> dict[str, Any]:
    """The same answer from the command line (its own process): results.json and the CPU it took."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    values = {**SETS, "materials.tissue_scale": scale, **(extra or {})}
    sets = [a for k, v in values.items() for a in ("--set", f"{k}={v}")]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", *sets, "--no-pictures",
                           "--out", str(out)], env=env, cwd=ROOT, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"suture-fem run exited {proc.returncode}: {proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"cpu_s": cpu, "results": json.loads((out / "results.json").read_text())}


def in_process(answers: int, out: Path | None, start: str) -> tuple[list[dict[str, Any]], list[float]]:
    """The first answer and the later ones, each with its CPU split and counters (results.json in ``out``/model_i)."""
    from mpi4py import MPI

    from suture_fem import Model, Scene

    meter = Meter()
    install(meter)
    scales = [1.0] + [round(0.8 + 0.45 * i / max(answers - 1, 1), 4) for i in range(answers)]
    rows = []
    for i, scale in enumerate(scales):
        imports0 = IMPORTS.count
        t0 = time.process_time()
        if i == 0:
            model = Model(Scene.builtin("paper").with_values(SETS), MPI.COMM_SELF)
        else:
            model.set({"materials.tissue_scale": scale})
        results = model.solve(out / f"model_{i}" if out is not None else None, start=start).to_dict()
        cpu = time.process_time() - (T_START if i == 0 else t0)
        parts, calls = meter.take()
        outputs = parts.get("outputs", 0.0) + parts.get("thread_end", 0.0)
        rows.append({"answer": i, "tissue_scale": scale, "cpu_s": cpu, "newton_s": parts.get("newton", 0.0),
                     "outputs_s": outputs, "critical_distance_s": parts.get("critical_distance", 0.0),
                     "other_s": cpu - parts.get("newton", 0.0) - outputs, "imports": IMPORTS.count - imports0,
                     "meshing_calls": calls.get("meshing", 0), "form_loading_calls": calls.get("form_loading", 0),
                     "usum_mm": results["usum_mm"], "newton_iterations": results["newton_iterations"],
                     "results": results})
    return rows, scales


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--answers", type=int, default=10, help="later answers (default 10)")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "many_answers"))
    parser.add_argument("--no-write", action="store_true",
                        help="in-process answers write no results.json (the command line always does)")
    parser.add_argument("--start", choices=("rest", "previous"), default="rest",
                        help="later answers from rest (default) or from the previous answer's states (warm)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, scales = in_process(args.answers, None if args.no_write else out, args.start)
    skip = NOT_COMPARED | (WARM_NOT_COMPARED if args.start == "previous" else set())
    for row, scale in zip(rows, scales):
        cli = cli_answer(scale, out / f"cli_{row['answer']}")
        row["cli_cpu_s"] = cli["cpu_s"]
        row.update(compare(row.pop("results"), cli["results"], skip))
        if args.start == "previous" and row["answer"] > 0:  # the command line against itself on another path
            other = cli_answer(scale, out / f"cli_other_{row['answer']}", OTHER_PATH)["results"]
            cli["results"]["scene"], other["scene"] = None, None  # the step key differs by design
            own = compare(other, cli["results"], skip)
            row.update({f"cli_other_path_{k}": v for k, v in own.items()})
    print(table(rows))
    verdict = targets(rows[1:])
    for line in verdict["lines"]:
        print(line)
    print(f"peak memory of this process (the Model and its kept search data): "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    record = {"scene": "paper", "sets": SETS, "start": args.start, "other_path": OTHER_PATH,
              "in_process_writes_results": not args.no_write, "rows": rows,
              "targets": verdict["met"],
              "python": sys.version.split()[0], "load": os.getloadavg(),
              "peak_memory_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
    (out / "many_answers.json").write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {out / 'many_answers.json'}")
    return 0


def table(rows: list[dict[str, Any]]) -> str:
    head = (f"{'answer':>6} {'scale':>6} {'CPU s':>7} {'Newton':>7} {'outputs':>7} {'(CD)':>6} {'other':>6} "
            f"{'out %':>6} {'imports':>7} {'meshes':>6} {'forms':>5} {'CLI CPU':>7} {'ratio':>6} {'max rel diff':>12} "
            f"{'>1e-10':>7}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(f"{r['answer']:>6} {r['tissue_scale']:>6.3f} {r['cpu_s']:>7.2f} {r['newton_s']:>7.2f} "
                     f"{r['outputs_s']:>7.2f} {r['critical_distance_s']:>6.2f} {r['other_s']:>6.2f} "
                     f"{100 * r['outputs_s'] / r['cpu_s']:>5.1f}% {r['imports']:>7d} {r['meshing_calls']:>6d} "
                     f"{r['form_loading_calls']:>5d} {r['cli_cpu_s']:>7.2f} {r['cpu_s'] / r['cli_cpu_s']:>6.2f} "
                     f"{r['difference']:>12.2e} {r['above_1e-10']:>7d}" + _other_path(r))
    return "\n".join(lines)


def _other_path(r: dict[str, Any]) -> str:
    """With a warm start: the command line against itself along another load path (the yardstick)."""
    if "cli_other_path_difference" not in r:
        return ""
    return f"   CLI's own path: {r['cli_other_path_difference']:.2e} ({r['cli_other_path_above_1e-10']} above 1e-10)"


def targets(later: list[dict[str, Any]]) -> dict[str, Any]:
    """The issue's targets for the later answers, each met or not, with the numbers."""
    met = {
        "no_meshing_forms_imports": all(r["meshing_calls"] == 0 and r["form_loading_calls"] == 0 and r["imports"] == 0
                                        for r in later),
        "at_most_half_the_cli_cpu": all(r["cpu_s"] <= 0.5 * r["cli_cpu_s"] for r in later),
        "outputs_at_most_15_percent": all(r["outputs_s"] <= 0.15 * r["cpu_s"] for r in later),
        "equal_to_the_cli_to_1e-10": all(r["difference"] <= 1e-10 for r in later),
    }
    worst_ratio = max(r["cpu_s"] / r["cli_cpu_s"] for r in later)
    worst_share = max(r["outputs_s"] / r["cpu_s"] for r in later)
    lines = [f"target {k}: {'met' if v else 'NOT met'}" for k, v in met.items()]
    lines.append(f"  later answers: CPU / CLI CPU at most {worst_ratio:.2f}; outputs at most {100 * worst_share:.1f} % "
                 f"of an answer; largest relative difference from the CLI {max(r['difference'] for r in later):.1e}")
    own = [r["cli_other_path_difference"] for r in later if "cli_other_path_difference" in r]
    if own:
        lines.append(f"  the command line's own answers along another load path differ by up to {max(own):.1e}")
    return {"met": met, "lines": lines}


if __name__ == "__main__":
    sys.exit(main())
