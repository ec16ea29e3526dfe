"""Benchmark: one scene on 1 and 2 MPI ranks, and sweep throughput for two ways of using 2 ranks.

1. One scene (default: the paper scene, 4 cones, degree 2, 4 N) solved as `suture-fem run` solves it
   under `mpirun -n 1` and `-n 2`: wall time, speed-up, the CPU seconds and peak resident memory of every
   rank, and the memory the package estimated before meshing (its "mesh estimate" line).
2. One sweep (default: 1-4 cones x 1, 2 N at degree 1, 8 scenes) under `mpirun -n 2` as one group
   of 2 ranks (`--ranks-per-scene 2`) and as two groups of 1 rank: scenes per minute.

The ranks run this file as a worker, which calls the library (`pipeline.run_scene`, the sweep study)
the way the command line does, so that it can measure each rank's memory after the solve.

Each measurement is a fresh `mpirun`, so form compilation is served from the FFCx cache (warm it
with one run first: `--warmup`). The load average is recorded before and after every measurement:
on a shared machine it says how much of the machine the benchmark really had.

    .venv/bin/python benchmarks/parallel.py [--scene paper --set KEY=VALUE ...] [--sweep-cones 1 2 3 4]
        [--skip-scene] [--skip-sweep] [--out benchmarks/out/parallel.json]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.support.io import write_json  # noqa: E402


def mpi_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMPI_MCA_rmaps_base_oversubscribe="1")
    return env


def solve(job: dict, comm) -> int:
    """What `suture-fem run` or `suture-fem sweep` does for JOB; returns the command's exit code.

    JOB: {"run": scene, "set": [KEY=VALUE, ...], "out": dir} or {"sweep": file, "out": dir, "ranks_per_scene": k}.
    """
    from suture_fem.support.errors import SolveStopped, SutureFemError

    try:
        if "run" in job:
            from suture_fem.pipeline import load_scene, run_scene

            run_scene(load_scene(job["run"], job["set"]), Path(job["out"]), comm)
            return 0
        from suture_fem.studies.sweep import load_sweep, log_per_group, run_sweep

        log_per_group(None, comm.rank == 0)
        sweep = load_sweep(job["sweep"], out=job["out"])
        data, _ = run_sweep(sweep, comm, job["ranks_per_scene"])
        return 0 if data["counts"].get("converged", 0) == len(sweep.cases) else SolveStopped.exit_code
    except SutureFemError as exc:
        return exc.exit_code


def worker(job: dict) -> int:
    """Solve JOB on every rank, then write every rank's peak memory and CPU seconds to $BENCH_MEMORY."""
    from mpi4py import MPI

    from suture_fem.support.logging import setup_logging

    setup_logging(MPI.COMM_WORLD)
    code = solve(job, MPI.COMM_WORLD)
    usage = resource.getrusage(resource.RUSAGE_SELF)
    peaks = MPI.COMM_WORLD.gather(round(usage.ru_maxrss / 1024.0, 1), root=0)  # kB on Linux
    cpu = MPI.COMM_WORLD.gather(round(usage.ru_utime + usage.ru_stime, 1), root=0)
    if MPI.COMM_WORLD.rank == 0:
        write_json(os.environ["BENCH_MEMORY"], {"peak_rss_mb_per_rank": peaks, "cpu_s_per_rank": cpu})
    return code


def launch(ranks: int, job: dict, tmp: Path, ok: tuple[int, ...] = (0,)) -> dict:
    """`mpirun -n RANKS` the worker on JOB (see `solve`); wall time, memory and load around it."""
    mpirun = shutil.which("mpirun") or "mpirun"
    memory = tmp / "memory.json"
    cmd = [mpirun, "-n", str(ranks), "--allow-run-as-root", "--oversubscribe", sys.executable, __file__,
           "--worker", json.dumps(job)]
    load_before = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env={**mpi_env(), "BENCH_MEMORY": str(memory)})
    wall = time.perf_counter() - t0
    if proc.returncode not in ok:
        raise SystemExit(f"{json.dumps(job)} on {ranks} rank(s) exited {proc.returncode}:\n{proc.stderr}")
    estimate = re.search(r"mesh estimate: .*?([0-9.]+) GiB", proc.stdout + proc.stderr)
    return {"ranks": ranks, "process_wall_s": round(wall, 2), **json.loads(memory.read_text()),
            "estimated_memory_gib": float(estimate.group(1)) if estimate else None,
            "load_1min_before": round(load_before, 2), "load_1min_after": round(os.getloadavg()[0], 2)}


def bench_scene(scene: str, overrides: list[str], tmp: Path) -> list[dict]:
    rows = []
    for ranks in (1, 2):
        out = tmp / f"scene{ranks}"
        row = launch(ranks, {"run": scene, "set": overrides, "out": str(out)}, tmp)
        res = json.loads((out / "results.json").read_text())
        t = res["timings_s"]
        row.update(dofs=res["dofs"], newton_iterations=res["newton_iterations"],
                   solve_wall_s=round(res["wall_time_s"], 2), assembly_s=t["assembly"],
                   linear_solve_s=t["linear_solve"], usum_mm=res["usum_mm"])
        rows.append(row)
    for row in rows:
        row["speedup"] = round(rows[0]["solve_wall_s"] / row["solve_wall_s"], 2)
    return rows


def bench_sweep(cones: list[int], forces: list[float], common: list[str], tmp: Path) -> list[dict]:
    lines = ['base = "paper"', "[set]"] + [f'"{k}" = {v}' for k, v in (o.split("=", 1) for o in common)]
    lines += ["[grid]", f'"geometry.cones" = {cones}', f'"loading.force_n" = {forces}']
    path = tmp / "throughput.toml"
    path.write_text("\n".join(lines) + "\n")
    rows = []
    for k in (2, 1):
        out = tmp / f"sweep_k{k}"
        row = launch(2, {"sweep": str(path), "out": str(out), "ranks_per_scene": k}, tmp, ok=(0, 3))
        summary = json.loads((out / "summary.json").read_text())
        last = json.loads((out / "last_run.json").read_text())
        n = len(summary["rows"])
        row.update(layout=f"{2 // k} group(s) of {k} rank(s)", scenes=n, counts=summary["counts"],
                   sweep_wall_s=last["wall_time_s"], scenes_per_min=round(60.0 * n / last["wall_time_s"], 2),
                   scenes_per_min_incl_startup=round(60.0 * n / row["process_wall_s"], 2))
        rows.append(row)
    return rows


def table(rows: list[dict], cols: list[str]) -> str:
    out = [" | ".join(cols)]
    out += [" | ".join(str(r.get(c, "")) for c in cols) for r in rows]
    return "\n".join(out)


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        sys.exit(worker(json.loads(sys.argv[2])))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="paper")
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="overrides of the single scene (default: none, the paper scene as it is)")
    ap.add_argument("--sweep-cones", type=int, nargs="+", default=[1, 2, 3, 4])
    ap.add_argument("--sweep-forces", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--sweep-set", action="append", default=None, metavar="KEY=VALUE",
                    help="overrides of every sweep scene (default: mesh.degree=1)")
    ap.add_argument("--warmup", action="store_true", help="solve each scene kind once first (fills the form cache)")
    ap.add_argument("--skip-scene", action="store_true")
    ap.add_argument("--skip-sweep", action="store_true")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/parallel.json"))
    args = ap.parse_args()
    sweep_set = args.sweep_set or ["mesh.degree=1"]
    record: dict = {"cpus": os.cpu_count(), "scene": args.scene, "overrides": args.overrides,
                    "open_mpi_settings": {k: v for k, v in os.environ.items() if k.startswith("OMPI_MCA_mpi_")},
                    "sweep": {"cones": args.sweep_cones, "forces_n": args.sweep_forces, "set": sweep_set}}
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        if args.warmup:
            launch(1, {"run": args.scene, "set": args.overrides, "out": str(tmp / "w1")}, tmp)
            launch(1, {"run": "paper", "set": sweep_set, "out": str(tmp / "w2")}, tmp)
        if not args.skip_scene:
            record["one_scene"] = bench_scene(args.scene, args.overrides, tmp)
            print(f"One scene ({args.scene} {' '.join(args.overrides)}), {os.cpu_count()} CPUs:")
            print(table(record["one_scene"], ["ranks", "dofs", "process_wall_s", "solve_wall_s", "speedup",
                                              "assembly_s", "linear_solve_s", "cpu_s_per_rank", "peak_rss_mb_per_rank",
                                              "estimated_memory_gib", "newton_iterations", "load_1min_before",
                                              "load_1min_after"]))
        if not args.skip_sweep:
            record["sweep_throughput"] = bench_sweep(args.sweep_cones, args.sweep_forces, sweep_set, tmp)
            print(f"\nSweep throughput on 2 ranks ({len(args.sweep_cones) * len(args.sweep_forces)} scenes):")
            print(table(record["sweep_throughput"], ["layout", "scenes", "sweep_wall_s", "scenes_per_min",
                                                     "scenes_per_min_incl_startup", "peak_rss_mb_per_rank",
                                                     "load_1min_before", "load_1min_after"]))
    write_json(args.out, record)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
