"""The cone counts' ramps in parallel processes: ``suture-fem reproduce-ramp``, one serial solve each.

mpi4py is imported (and MPI initialised) by the time a study runs, so forking this process is unsafe;
each case runs instead as its own ``python -P -m suture_fem.cli reproduce-ramp FOLDER/case.json``
(the package's command, as ``suture-fem convergence`` runs its rungs). The cases are split into
``jobs`` groups of about equal cost; this process solves the first group itself, one child process
per other group solves its cases one after the other (so ``jobs`` processes pay the imports, not one
per case). The parent writes each case (the resolved scene, the fields folder, the band to
propagate) to ``cones_N/case.json``; the child runs
:func:`~suture_fem.studies.reproduce.solve.solve_case`, exactly what the serial path runs, and writes
``results.json`` (the ramp), ``ramp.json`` (the stop and the bands) and the field files; the parent
reads them back. Each child's CPU time comes from its rusage (``os.wait4``). When the parent is
interrupted, its children are terminated; when it is killed, they end too (:mod:`~suture_fem.support.children`).
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.reproduce.solve import cpu_self, field_path, solve_case
from suture_fem.support import children
from suture_fem.support.errors import SutureFemError
from suture_fem.support.io import open_new, read_json, write_json

log = logging.getLogger("suture_fem")

CASE_FILE = "case.json"
RAMP_FILE = "ramp.json"


def default_jobs(cases: int) -> int:
    """min(cores this process may use, cases), at least 1."""
    return max(1, min(len(os.sched_getaffinity(0)), cases))


def groups(costs: dict[int, float], jobs: int) -> list[list[int]]:
    """The cases (cones -> estimated cost) in at most ``jobs`` groups of about equal cost.

    Longest processing time first: each case, costliest first, joins the group with the least cost so
    far. The first group is the costliest.
    """
    out: list[list[int]] = [[] for _ in range(max(1, min(jobs, len(costs))))]
    load = [0.0] * len(out)
    for n in sorted(costs, key=lambda k: (-costs[k], -k)):
        i = load.index(min(load))
        out[i].append(n)
        load[i] += costs[n]
    return sorted(out, key=lambda g: -sum(costs[n] for n in g))


def solve_in_processes(cases: dict[int, Scene], out: Path, comm: Any, fields_dir: Path | None,
                       band: tuple[str, float] | None, jobs: int,
                       costs: dict[int, float]) -> tuple[dict[int, dict[str, Any]], float]:
    """Solve every case (cones -> scene) in ``jobs`` processes; returns ({n: solved}, CPU s of all of them).

    The cases are split into ``jobs`` groups of about equal ``costs`` (:func:`groups`); this process
    solves the first group while one child process per other group solves its cases one after the
    other (each child pays the imports once). ``solved`` is
    :func:`~suture_fem.studies.reproduce.solve.solve_case`'s record, a child's grids loaded from the
    field files it wrote.
    """
    mine, *others = groups(costs, jobs)
    running: dict[int, tuple[list[int], subprocess.Popen, Any, float]] = {}
    solved: dict[int, dict[str, Any]] = {}
    cpu0 = cpu_self()
    try:
        for group in others:
            pid, proc, logfile = _start({n: cases[n] for n in group}, out, fields_dir, band)
            running[pid] = (group, proc, logfile, time.perf_counter())
        for n in mine:
            solved[n] = solve_case(cases[n], out / f"cones_{n}", comm, fields_dir, band)
        cpu = cpu_self() - cpu0
        while running:
            pid = next(iter(running))  # our children in turn (never another child's status)
            _, status, usage = os.wait4(pid, 0)
            group, proc, logfile, t0 = running.pop(pid)
            logfile.close()
            proc.returncode = os.waitstatus_to_exitcode(status)
            cpu += usage.ru_utime + usage.ru_stime
            log.info("cones %s: child process exit %d, %.1f s CPU, %.1f s wall", ",".join(map(str, group)),
                     proc.returncode, usage.ru_utime + usage.ru_stime, time.perf_counter() - t0)
            log_file = out / f"cones_{group[0]}" / "run.log"
            solved.update({n: _collect(n, out / f"cones_{n}", fields_dir, proc.returncode, log_file) for n in group})
    finally:
        for _, proc, logfile, _ in running.values():
            children.stop(proc)
            logfile.close()
    return {n: solved[n] for n in cases}, cpu


def _start(cases: dict[int, Scene], out: Path, fields_dir: Path | None,
           band: tuple[str, float] | None) -> tuple[int, subprocess.Popen, Any]:
    """A child process solving ``cases`` one after the other (its log: the first case's run.log)."""
    files = []
    for n, scene in cases.items():
        folder = out / f"cones_{n}"
        folder.mkdir(parents=True, exist_ok=True)
        for stale in (folder / RAMP_FILE, folder / "results.json", folder / "run.log"):
            stale.unlink(missing_ok=True)
        files.append(write_json(folder / CASE_FILE, {"scene": scene.as_dict(), "band": band,
                                                     "fields_dir": None if fields_dir is None else str(fields_dir)}))
    # -P: the current folder is not on the child's module path (a stray .py there must not run)
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "reproduce-ramp", *map(str, files)]
    logfile = open_new(files[0].parent / "run.log")  # closed when the child ends
    proc = children.popen(cmd, stdout=logfile, stderr=subprocess.STDOUT)  # it ends with this process
    return proc.pid, proc, logfile


def _collect(n: int, folder: Path, fields_dir: Path | None, code: int, log_file: Path) -> dict[str, Any]:
    """A child's record: its results.json and ramp.json, the grids from its field files."""
    if not (folder / RAMP_FILE).exists() or not (folder / "results.json").exists():
        tail = log_file.read_text(errors="replace").strip().splitlines()[-1:] if log_file.exists() else []
        raise SutureFemError(f"{n} cone(s): the ramps' process ended with exit code {code} without this one's "
                             f"results ({log_file}: {tail[0] if tail else 'empty'})")
    ramp = read_json(folder / RAMP_FILE)
    grids = {}
    if fields_dir is not None:
        from suture_fem import plots

        grids = {f: plots.load_grid(field_path(fields_dir, n, f)) for f in ramp["forces_n"]}
    return {"results": read_json(folder / "results.json"), "stopped": ramp["stopped"],
            "bands": {float(f): b for f, b in ramp["bands"]}, "grids": grids}


def run_case_files(paths: list[Path], comm: Any) -> int:
    """The child: solve the case of every path (``case.json``) in turn; exit 3 when one stopped, else 0."""
    codes = [run_case_file(path, comm) for path in paths]
    return max(codes, default=0)


def run_case_file(path: Path, comm: Any) -> int:
    """Solve the case in ``path`` (``case.json``) on ``comm``; write ramp.json beside it; 0, or 3 if it stopped."""
    from suture_fem.pipeline import check
    from suture_fem.scene.load import validate

    case = read_json(path)
    scene = Scene.from_dict(validate(case["scene"]))
    check(scene)
    fields_dir = Path(case["fields_dir"]) if case["fields_dir"] else None
    band = tuple(case["band"]) if case["band"] else None
    solved = solve_case(scene, path.parent, comm, fields_dir, band)
    forces = [rec["force_n"] for rec in solved["results"].get("at_forces", [])]
    if comm.rank == 0:
        write_json(path.parent / RAMP_FILE, {"stopped": solved["stopped"], "bands": sorted(solved["bands"].items()),
                                             "forces_n": [round(f, 6) for f in forces]})
    return 3 if solved["stopped"] else 0
