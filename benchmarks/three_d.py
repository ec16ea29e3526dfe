"""Benchmark: the 3-D cylinder (geometry.dimension = 3) against the axisymmetric model, its cost, its solvers.

Parts (each run is ``suture-fem run paper --set ...`` in its own process under GNU time, which gives its
CPU seconds, summed over every MPI rank, and its peak resident memory, the largest of any one rank):

* ``ladder``: the paper's tissue and hollow cones, P1, pulled to 4 N with a report at 1 N, at 1 cone
  (and 4 cones on the two coarser rungs), on a 3-D mesh ladder: the [mesh] sizes times 4, 2.83 and 2
  (each rung's sizes sqrt 2 smaller, about 2.8 times the tetrahedra), against the 2-D axisymmetric
  model at P1 on the same sizes and at P2 one refinement finer (the 2-D reference). Quantities: USUM,
  the thread end's displacement, the strain energy, the tissue's SEQV and EPTOEQV outside the rims
  (``seqv_outside_rim_pa``, ``eptoeqv_outside_rim``) and their peaks.
* ``ranks``: one rung (sizes times 2, 1 cone, 1 N) on 1 and 2 MPI ranks: CPU, wall, peak memory per rank.
* ``solvers``: MUMPS against GAMG (and hypre) at 0.25 N on the rungs of ``--solver-factors`` (x2 and x1.41;
  hypre on the first only, ``--solver-methods`` to change): the linear solve's seconds per Newton iteration,
  the crossover of ``solver.linear_method = "auto"``.
* ``critical_distance``: the tissue's converged measures (SEQV and EPTOEQV averaged over a ball of the
  default critical distance, 0.1 mm, where largest; near the cones too) at 1 N, 1 and 4 cones, on the
  ladder's 3-D rungs and, for 1 cone, with the rims alone refined (rim size 0.05 and 0.025 mm, the rest
  at x2), against the 2-D model (P1 on the same sizes, P2 one refinement finer); the outputs' wall
  seconds (``timings_s.outputs``). Each run is written to the JSON as it ends; not in the
  default parts.
* ``p2``: quadratic tetrahedra (``mesh.degree = 2``), 1 cone, pulled to 1 N, the critical-distance ball at
  its default: the [mesh] sizes times 4, 2.83, 2, 1.41, 1 (``--p2-factors``), coarsest first, against 2-D P2
  on the same sizes and the 2-D reference (P2, refinement 1). A rung is run only while it is predicted under
  ``--cpu-limit`` CPU seconds and ``--memory-limit`` GiB (the last rung's measured dofs, CPU and memory grown
  by the package's own estimate before meshing, CPU as its 2.2th power); ``solver.linear_method`` at its
  default ("auto": MUMPS under ``solver.iterative_from_dofs``). ``--p2-set`` adds scene keys to every run
  (docs/three-d.md runs it with ``solver.gent_limit_fraction=1.0``: with the default check P2 stops at the
  outer surface's corner before 1 N). Each run is written to the JSON as it ends; not in the default parts.

    .venv/bin/python benchmarks/three_d.py [--parts ladder ranks solvers critical_distance p2] \
        [--out benchmarks/out/three_d] [--cpu-limit 3600] [--memory-limit 8] [--p2-set KEY=VALUE ...] \
        [--p2-name p2] [--p2-factors 4 2.83 2 1.41 1] [--solver-factors 2 1.41 1] \
        [--solver-methods direct gamg hypre]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.geometry.estimate_3d import estimate_3d  # noqa: E402
from suture_fem.geometry.gmsh_model import MeshSizes  # noqa: E402
from suture_fem.geometry.section import Geometry  # noqa: E402
from suture_fem.scene.load import parse_scene  # noqa: E402
from suture_fem.support.io import write_json  # noqa: E402

#: The 3-D scene's common keys: the outputs 3-D has, P1.
BASE_3D = ["geometry.dimension=3", "mesh.degree=1", "output.critical_distance_mm=0",
           'output.quantities=["usum","seqv","eptoeqv"]']
BASE_2D = ["output.critical_distance_mm=0", 'output.quantities=["usum","seqv","eptoeqv"]']
#: The same with the critical-distance average at its default radius (0.1 mm): a disc in 2-D, a ball in 3-D.
BASE_CD_3D = ["geometry.dimension=3", "mesh.degree=1", 'output.quantities=["usum","seqv","eptoeqv"]']
BASE_CD_2D = ['output.quantities=["usum","seqv","eptoeqv"]']
#: The [mesh] sizes at refinement 0 (defaults.toml): suture, rim, far.
SIZES = (0.15, 0.05, 1.2)
QUANTITIES = ("usum_mm", "thread_end_displacement_mm", "strain_energy_j")
TISSUE = ("seqv_outside_rim_pa", "eptoeqv_outside_rim", "seqv_pa", "eptoeqv")


def sized(factor: float) -> list[str]:
    """The [mesh] sizes times ``factor``."""
    s, r, f = (round(v * factor, 6) for v in SIZES)
    return [f"mesh.size_suture_mm={s}", f"mesh.size_rim_mm={r}", f"mesh.size_far_mm={f}"]


def run(label: str, overrides: list[str], tmp: Path, ranks: int = 1, verbose: bool = False) -> dict:
    """One run in its own process: results.json, CPU (all ranks), wall, peak memory (largest rank).

    ``verbose``: the run logs its steps (``-v``) to ``<label>.log`` beside its folder as it goes.
    """
    out = tmp / label.replace(" ", "_")
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", *(["-v"] if verbose else []), "run", "paper",
           *[a for o in overrides for a in ("--set", o)], "--no-pictures", "--out", str(out)]
    if ranks > 1:
        cmd = [shutil.which("mpirun"), "-n", str(ranks), "--allow-run-as-root", "--oversubscribe", *cmd]
    stats = tmp / (label.replace(" ", "_") + ".time")
    t0 = time.perf_counter()
    log = tmp / (label.replace(" ", "_") + ".log")
    with log.open("w") as err:
        proc = subprocess.run(["/usr/bin/time", "-f", "%U %S %M", "-o", str(stats), *cmd], stdout=subprocess.PIPE,
                              stderr=err, text=True, cwd=ROOT, env=dict(os.environ, OMP_NUM_THREADS="1"))
    proc.stderr = log.read_text()
    wall = time.perf_counter() - t0
    user, system, peak_kb = stats.read_text().split()[-3:]
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else {}
    res.update(label=label, exit_code=proc.returncode, process_wall_s=wall, process_cpu_s=float(user) + float(system),
               peak_memory_mb=int(peak_kb) / 1024, ranks=ranks, log_tail=proc.stderr.splitlines()[-20:])
    print(f"  {label}: exit {proc.returncode}, {res.get('dofs', 0):,} dofs, {res['process_cpu_s']:.1f} s CPU, "
          f"{wall:.1f} s wall, {res['peak_memory_mb']:.0f} MB", flush=True)
    return res


def at(res: dict, force: float) -> dict:
    """The reported state at a force (empty when the run did not reach it)."""
    return next((s for s in res.get("at_forces", []) if abs(s["force_n"] - force) < 1e-9), {})


def summary(res: dict, force: float) -> dict:
    """The compared quantities of one run at one force."""
    s = at(res, force)
    tissue = s.get("regions", {}).get("tissue", {})
    diagnosis = res.get("diagnosis") or {}
    return {**{q: s.get(q) for q in QUANTITIES}, **{f"tissue_{q}": tissue.get(q) for q in TISSUE},
            "seqv_outside_rim_at_rz_mm": rz(tissue.get("seqv_outside_rim_pa_at_mm")),
            "stop_cause": diagnosis.get("cause"), "load_reached_n": diagnosis.get("load_reached_n"),
            "stop_detail": diagnosis.get("detail")}


def rz(at_mm: list[float] | None) -> list[float] | None:
    """A location as (r, z) mm: 3-D (x, y, z) with the thread along y -> (sqrt(x^2 + z^2), y)."""
    if not at_mm:
        return None
    if len(at_mm) == 3:
        return [round((at_mm[0] ** 2 + at_mm[2] ** 2) ** 0.5, 4), round(at_mm[1], 4)]
    return [round(v, 4) for v in at_mm]


def ladder(tmp: Path) -> list[dict]:
    """The 3-D rungs and the 2-D references at 1 and 4 cones, 1 and 4 N."""
    rows = []
    for cones, factors in ((1, (4.0, 2.83, 2.0)), (4, (4.0, 2.83))):
        common = [f"geometry.cones={cones}", "loading.force_n=4.0", "loading.report_forces_n=[1.0]"]
        runs = [("2-D P2 ref. 1", run(f"2d_p2_r1_{cones}", [*BASE_2D, *common, "mesh.refinement=1"], tmp))]
        runs += [(f"2-D P1 x{f:g}", run(f"2d_p1_{cones}_{f:g}", [*BASE_2D, *common, "mesh.degree=1", *sized(f)], tmp))
                 for f in factors]
        runs += [(f"3-D P1 x{f:g}", run(f"3d_p1_{cones}_{f:g}", [*BASE_3D, *common, *sized(f)], tmp))
                 for f in factors]
        for name, res in runs:
            for force in (1.0, 4.0):
                rows.append({"cones": cones, "model": name, "force_n": force, "dofs": res.get("dofs"),
                             "cells": res.get("cells"), "cpu_s": res["process_cpu_s"],
                             "peak_memory_mb": res["peak_memory_mb"], "newton_iterations": res.get("newton_iterations"),
                             "status": res.get("status"), **summary(res, force)})
    return rows


def ranks(tmp: Path) -> list[dict]:
    """One rung on 1 and 2 ranks."""
    scene = [*BASE_3D, "geometry.cones=1", "loading.force_n=1.0", *sized(2.0)]
    rows = []
    for n in (1, 2):
        res = run(f"ranks_{n}", scene, tmp, ranks=n)
        rows.append({"ranks": n, "dofs": res.get("dofs"), "cpu_s": res["process_cpu_s"],
                     "wall_s": res["process_wall_s"], "peak_memory_mb_per_rank": res["peak_memory_mb"],
                     "newton_iterations": res.get("newton_iterations"), "timings_s": res.get("timings_s"),
                     "usum_mm": res.get("usum_mm")})
    return rows


def solvers(tmp: Path, factors: tuple[float, ...] = (2.0, 1.41),
            methods: tuple[str, ...] = ("direct", "gamg", "hypre")) -> list[dict]:
    """Direct against algebraic multigrid, seconds per linear solve, on the rungs ``factors`` at 0.25 N.

    hypre's BoomerAMG (which failed on the first solve at x2, falling back to MUMPS) on the first rung only.
    """
    rows = []
    for i, f in enumerate(factors):
        for method in (m for m in methods if m != "hypre" or i == 0):
            scene = [*BASE_3D, "geometry.cones=1", "loading.force_n=0.25", *sized(f),
                     f'solver.linear_method="{method}"']
            res = run(f"solver_{method}_{f:g}", scene, tmp)
            t = res.get("timings_s", {})
            its = max(res.get("newton_iterations") or 1, 1)
            rows.append({"factor": f, "method": method, "dofs": res.get("dofs"), "cpu_s": res["process_cpu_s"],
                         "peak_memory_mb": res["peak_memory_mb"], "newton_iterations": res.get("newton_iterations"),
                         "linear_solve_s": t.get("linear_solve"), "per_iteration_s": (t.get("linear_solve") or 0) / its,
                         "recorded_solver": res.get("linear_solver"), "fallbacks": res.get("linear_solver_fallbacks"),
                         "usum_mm": res.get("usum_mm")})
    return rows


#: The critical-distance measures compared, in the whole tissue.
MEASURES = ("seqv_cd_pa", "eptoeqv_cd", "seqv_cd_cone_pa", "eptoeqv_cd_cone")


def critical_distance(tmp: Path, out: Path | None = None) -> list[dict]:
    """The converged stress measures at 1 N on the 3-D rungs (coarse first) and the 2-D references."""
    runs = [(cones, "2-D P2 ref. 1", [*BASE_CD_2D, f"geometry.cones={cones}", "mesh.refinement=1"]) for cones in (1, 4)]
    runs += [(cones, f"2-D P1 x{f:g}", [*BASE_CD_2D, f"geometry.cones={cones}", "mesh.degree=1", *sized(f)])
             for cones, f in ((1, 4.0), (1, 2.83), (1, 2.0), (4, 4.0), (4, 2.83))]
    runs += [(cones, f"3-D P1 x{f:g}", [*BASE_CD_3D, f"geometry.cones={cones}", *sized(f)])
             for cones, f in ((1, 4.0), (4, 4.0), (1, 2.83), (4, 2.83), (1, 2.0))]
    # the ladder's rims are meshed no finer than the ball's radius: the rims alone refined, the rest at x2
    runs += [(1, f"3-D P1 x2, rim {rim:g}", [*BASE_CD_3D, "geometry.cones=1", *sized(2.0), f"mesh.size_rim_mm={rim}"])
             for rim in (0.05, 0.025)]
    rows = []
    for cones, model, overrides in runs:
        res = run(f"cd_{cones}_{model}", [*overrides, "loading.force_n=1.0", "loading.report_forces_n=[]"], tmp)
        tissue = at(res, 1.0).get("regions", {}).get("tissue", {})
        rows.append({"cones": cones, "model": model, "dofs": res.get("dofs"), "cells": res.get("cells"),
                     "cpu_s": res["process_cpu_s"], "peak_memory_mb": res["peak_memory_mb"],
                     "outputs_wall_s": res.get("timings_s", {}).get("outputs"), "status": res.get("status"),
                     "usum_mm": at(res, 1.0).get("usum_mm"), **{f"tissue_{q}": tissue.get(q) for q in MEASURES},
                     **{f"{q}_at_rz_mm": rz(tissue.get(f"{q}_at_mm")) for q in MEASURES},
                     **{f"{q}_at_mm": tissue.get(f"{q}_at_mm") for q in MEASURES}})
        if out is not None:  # each run as it ends: the finer rungs take long
            write_json(out / "critical_distance.json", {"part": "critical_distance", "rows": rows})
    return rows


#: The P2 ladder's size factors, coarsest first (each rung's sizes sqrt 2 smaller).
P2_FACTORS = (4.0, 2.83, 2.0, 1.41, 1.0)
#: P1's CPU growth with the dofs on the ladder's finest rungs (765 -> 2,726 CPU s for 1.77 times the dofs).
CPU_EXPONENT = 2.2


def estimated(overrides: list[str]) -> dict:
    """The package's own estimate before meshing (tetrahedra, unknowns, GiB) of a 3-D scene."""
    scene = parse_scene("paper", overrides)
    e = estimate_3d(Geometry.from_section(scene.geometry), MeshSizes.from_section(scene.mesh), scene.mesh.degree)
    return {"cells": e.cells, "unknowns": e.unknowns, "memory_gib": e.memory_gib}


def predicted(done: list[dict], estimate: dict) -> dict:
    """The next rung's dofs, CPU s and peak GiB from the last rung solved and the estimate's growth."""
    if not done:
        return {"dofs": estimate["unknowns"], "cpu_s": None, "memory_gib": estimate["memory_gib"]}
    last = done[-1]
    growth = estimate["unknowns"] / last["estimate"]["unknowns"]  # the estimate's ratio; its own scale is off
    return {"dofs": int(last["dofs"] * growth), "cpu_s": last["cpu_s"] * growth**CPU_EXPONENT,
            "memory_gib": last["peak_memory_mb"] / 1024 * growth**1.3}


def p2_row(model: str, factor: float | None, res: dict, reference: float | None) -> dict:
    """One run of the P2 ladder: cost, USUM, its error against the reference, the tissue's ball averages."""
    state = at(res, 1.0)
    tissue = state.get("regions", {}).get("tissue", {})
    usum = state.get("usum_mm")
    return {"model": model, "factor": factor, "dofs": res.get("dofs"), "cells": res.get("cells"),
            "cpu_s": res["process_cpu_s"], "peak_memory_mb": res["peak_memory_mb"],
            "newton_iterations": res.get("newton_iterations"), "linear_solver": res.get("linear_solver"),
            "fallbacks": res.get("linear_solver_fallbacks"), "status": res.get("status"),
            "stop": (res.get("diagnosis") or {}).get("cause"),
            "load_reached_n": (res.get("diagnosis") or {}).get("load_reached_n"), "log_tail": res.get("log_tail"),
            "timings_s": res.get("timings_s"), "usum_mm": usum,
            "usum_error_pct": None if usum is None or reference is None else 100.0 * (usum / reference - 1.0),
            **{f"tissue_{q}": tissue.get(q) for q in MEASURES},
            **{f"{q}_at_rz_mm": rz(tissue.get(f"{q}_at_mm")) for q in MEASURES}}


def p2(tmp: Path, out: Path, limits: tuple[float, float], extra: list[str], name: str,
       factors: tuple[float, ...] = P2_FACTORS) -> list[dict]:
    """The P2 3-D ladder at 1 cone, 1 N, coarsest first, while the next rung is predicted to fit the limits.

    ``limits``: the largest predicted CPU s and peak GiB of a rung; ``extra``: scene keys for every run of the
    part (``--p2-set``); ``name``: the JSON's name (``--p2-name``); ``factors``: the rungs (``--p2-factors``).
    """
    cpu_limit, memory_limit = limits
    common = ["geometry.cones=1", "loading.force_n=1.0", "loading.report_forces_n=[]", *BASE_CD_2D, *extra]
    ref = run("p2_2d_ref", [*common, "mesh.refinement=1"], tmp)
    reference = at(ref, 1.0).get("usum_mm")
    rows, done = [p2_row("2-D P2 ref. 1", None, ref, reference)], []
    for f in factors:
        scene = [*common, "geometry.dimension=3", "mesh.degree=2", *sized(f)]
        estimate = estimated(scene)
        guess = predicted(done, estimate)
        print(f"  3-D P2 x{f:g}: predicted {guess}", flush=True)
        if (guess["cpu_s"] or 0) > cpu_limit or guess["memory_gib"] > memory_limit:
            rows.append({"model": f"3-D P2 x{f:g}", "factor": f, "status": "not run", "predicted": guess})
            break
        res = run(f"p2_3d_{f:g}", scene, tmp, verbose=True)
        row = p2_row(f"3-D P2 x{f:g}", f, res, reference)
        row.update(predicted=guess, estimate=estimate)
        two_d = run(f"p2_2d_{f:g}", [*common, *sized(f)], tmp)
        rows += [row, p2_row(f"2-D P2 x{f:g}", f, two_d, reference)]
        write_json(out / f"{name}.json", {"part": "p2", "set": extra, "reference_usum_mm": reference, "rows": rows})
        if row["status"] != "converged":
            break
        done.append(row)
    write_json(out / f"{name}.json", {"part": "p2", "set": extra, "reference_usum_mm": reference, "rows": rows})
    return rows


def table(rows: list[dict], keys: list[str]) -> str:
    """A markdown table of the rows' keys (numbers to 4 significant digits)."""
    def fmt(v: object) -> str:
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--parts", nargs="+", default=["ladder", "ranks", "solvers"])
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "three_d"))
    parser.add_argument("--cpu-limit", type=float, default=3600.0, help="p2: largest predicted CPU s of a rung")
    parser.add_argument("--memory-limit", type=float, default=8.0, help="p2: largest predicted peak GiB of a rung")
    parser.add_argument("--p2-set", nargs="*", default=[], help="p2: scene keys KEY=VALUE for every run of the part")
    parser.add_argument("--p2-name", default="p2", help="p2: the JSON's file name (without .json)")
    parser.add_argument("--p2-factors", nargs="+", type=float, default=list(P2_FACTORS), help="p2: the rungs' factors")
    parser.add_argument("--solver-factors", nargs="+", type=float, default=[2.0, 1.41], help="solvers: the rungs")
    parser.add_argument("--solver-methods", nargs="+", default=["direct", "gamg", "hypre"], help="solvers: methods")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    parts = {"ladder": ladder, "ranks": ranks,
             "solvers": lambda tmp: solvers(tmp, tuple(args.solver_factors), tuple(args.solver_methods)),
             "critical_distance": lambda tmp: critical_distance(tmp, out),
             "p2": lambda tmp: p2(tmp, out, (args.cpu_limit, args.memory_limit), args.p2_set, args.p2_name,
                                  tuple(args.p2_factors))}
    columns = {
        "ladder": ["cones", "model", "force_n", "dofs", "cpu_s", "peak_memory_mb", "status", *QUANTITIES,
                   *[f"tissue_{q}" for q in TISSUE], "seqv_outside_rim_at_rz_mm", "stop_cause", "load_reached_n"],
        "ranks": ["ranks", "dofs", "cpu_s", "wall_s", "peak_memory_mb_per_rank", "newton_iterations", "usum_mm"],
        "solvers": ["factor", "method", "dofs", "cpu_s", "peak_memory_mb", "newton_iterations", "linear_solve_s",
                    "per_iteration_s", "recorded_solver", "fallbacks", "usum_mm"],
        "critical_distance": ["cones", "model", "dofs", "cpu_s", "peak_memory_mb", "outputs_wall_s", "status",
                              "usum_mm", *[f"tissue_{q}" for q in MEASURES], *[f"{q}_at_rz_mm" for q in MEASURES]],
        "p2": ["model", "dofs", "cells", "cpu_s", "peak_memory_mb", "newton_iterations", "linear_solver", "status",
               "usum_mm", "usum_error_pct", *[f"tissue_{q}" for q in MEASURES]],
    }
    with tempfile.TemporaryDirectory(prefix="three_d_") as tmp:
        for name in args.parts:
            print(f"{name}:", flush=True)
            rows = parts[name](Path(tmp))
            if name != "p2":  # p2 writes its own, with the reference and the keys set
                write_json(out / f"{name}.json", {"part": name, "rows": rows})
            print(table(rows, columns[name]), flush=True)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
