"""``suture-fem sweep SWEEP.toml``: many scenes, shared among groups of MPI ranks.

A sweep file names a base scene and what to vary, either as a grid (every combination, the first
key varying slowest) or as an explicit list of override tables::

    base = "paper"                 # a built-in scene or a scene file (relative to the sweep file)
    out = "results/cone_study"     # optional; default results/<sweep file name>

    [set]                          # optional: overrides for every scene
    "mesh.degree" = 1

    [grid]                         # either this ...
    "geometry.cones" = [1, 2, 3, 4]
    "loading.force_n" = [1.0, 2.0]

    [[scenes]]                     # ... or this, one table per scene
    "geometry.cones" = 2

Keys are dotted scene keys, quoted or written as nested tables (``[grid.geometry]``). Each scene
is the base scene with ``--set KEY=VALUE`` overrides (the sweep's ``[set]``, the command line's
``--set``, then the scene's own), so ``status.json`` records the ``suture-fem run`` command that
reproduces it.

Under ``mpirun -n N ... --ranks-per-scene K`` the world communicator is split into N/K groups
(``comm.Split``); each scene is solved by one group on the group's communicator. Scenes are dealt
round-robin (``--schedule static``) or taken one at a time from a counter in an MPI window
(``--schedule dynamic``: a group that finishes early takes the next scene).

Every scene has a folder ``OUT/NNN-HASH`` (position in the sweep, and a hash of the base scene's
content and the scene's overrides). It is filled in a hidden staging
folder and renamed into place when the scene is finished, so it is complete or absent; it holds
``results.json`` (and the fields if asked) and ``status.json``: status (converged, stopped,
invalid, error), exit code, message, the reproducing command, and ``solve_count``. A scene that
fails records its diagnosis and the sweep goes on. Running the same sweep again skips the scenes
whose folder exists (converged, stopped or invalid; an "error" is retried) unless ``--redo``
(``--redo failed``: only the ones that did not converge).

At the end world rank 0 writes ``OUT/summary.{json,csv,md}`` from the folders (``--summary-only``
rebuilds them without solving) and ``OUT/last_run.json`` (what this run solved and skipped).
Exit code: 0 when every scene converged, 3 when the sweep finished with failed scenes, 2 for a
bad sweep file or arguments.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import io
import itertools
import json
import logging
import os
import platform
import shlex
import shutil
import time
import tomllib
import traceback
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.pipeline import load_scene
from suture_fem.scene import Scene
from suture_fem.scene.load import read_scene_source
from suture_fem.support.errors import SceneError, SolveStopped, SutureFemError
from suture_fem.support.io import read_json, write_json, write_text
from suture_fem.support.parallel import on_root, wait

log = logging.getLogger("suture_fem.sweep")

SWEEP_KEYS = ("base", "out", "set", "grid", "scenes")
FINISHED = ("converged", "stopped", "invalid")  # a folder with one of these is not solved again
EXIT_CODES = {"converged": 0, "stopped": SolveStopped.exit_code, "invalid": SceneError.exit_code}
#: How long a rank that failed alone waits for the rest of its group before aborting every rank
#: (the others may be blocked in a collective call that will never complete).
STRAGGLER_TIMEOUT_S = 120.0
#: Summary columns taken from results.json (dotted paths), after the varied keys.
RESULT_COLUMNS = (
    "usum_mm", "regions.tissue.seqv_pa", "regions.tissue.eptoeqv", "seqv_pa", "eptoeqv", "seqv_outside_rim_pa",
    "force_reached_n", "thread_end_displacement_mm", "reaction_force_n", "load_steps", "newton_iterations",
    "cutbacks", "dofs",
)
STATUS_COLUMNS = ("ranks", "wall_time_s", "solve_count", "message")


class SweepError(SceneError):
    """A bad sweep file or sweep argument (exit code 2)."""


# ---------------------------------------------------------------------------------------------
# The plan: the sweep file expanded into cases (deterministic, the same on every rank)


@dataclass(frozen=True)
class Case:
    """One scene of a sweep.

    Attributes:
        index: position in the sweep (0-based).
        varied: this scene's own overrides, dotted key -> value.
        overrides: every ``KEY=VALUE`` applied to the base scene, in order.
        scene: the validated scene, or None when it does not validate (``error`` says why).
        name: the folder name, ``NNN-HASH``.
    """

    index: int
    varied: dict[str, Any]
    overrides: tuple[str, ...]
    scene: Scene | None
    error: str | None
    name: str


@dataclass
class Sweep:
    path: Path
    base: str
    out: Path
    cases: list[Case]
    varied_keys: list[str] = field(default_factory=list)


def toml_value(value: Any) -> str:
    """A value written as TOML, the way ``--set KEY=VALUE`` reads it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise SweepError(f"sweep value {value!r}: expected a number, string, boolean, list or table")


def _flatten(tree: dict[str, Any], where: str, prefix: str = "") -> dict[str, Any]:
    """Nested tables to dotted keys (an empty table stays a value, e.g. petsc_options = {})."""
    if not isinstance(tree, dict):
        raise SweepError(f"{where}: expected a table of scene keys, got {tree!r}")
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, dict) and value:
            flat.update(_flatten(value, where, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _short_hash(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:8]


def load_sweep(path: str | Path, extra: list[str] | None = None, out: str | Path | None = None) -> Sweep:
    """Read and expand a sweep file; ``extra`` are ``KEY=VALUE`` overrides for every scene.

    Raises SweepError for a malformed sweep file; a scene that does not validate becomes a case
    with its error (it is recorded, not raised).
    """
    path = Path(path)
    if not path.is_file():
        raise SweepError(f"sweep file {str(path)!r} does not exist")
    try:
        raw = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"sweep file {path}: not valid TOML: {exc}") from None
    unknown = sorted(set(raw) - set(SWEEP_KEYS))
    if unknown:
        raise SweepError(f"sweep file {path}: unknown key {unknown[0]} (allowed: {', '.join(SWEEP_KEYS)})")
    base = raw.get("base")
    if not isinstance(base, str) or not base:
        raise SweepError(f"sweep file {path}: key base: expected a built-in scene name or a scene file")
    if base.endswith(".toml") or (path.parent / base).is_file():
        base = str(path.parent / base)
    if ("grid" in raw) == ("scenes" in raw):
        raise SweepError(f"sweep file {path}: give exactly one of [grid] (every combination) or [[scenes]] (a list)")
    if "grid" in raw:
        grid = _flatten(raw["grid"], f"sweep file {path}: [grid]")
        if not grid:
            raise SweepError(f"sweep file {path}: [grid] is empty")
        for key, values in grid.items():
            if not isinstance(values, list) or not values:
                raise SweepError(f"sweep file {path}: grid key {key}: expected a non-empty list of values")
        variations = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())]
    else:
        if not isinstance(raw["scenes"], list) or not raw["scenes"]:
            raise SweepError(f"sweep file {path}: scenes: expected a non-empty array of tables ([[scenes]])")
        variations = [_flatten(t, f"sweep file {path}: scene {i}") for i, t in enumerate(raw["scenes"])]
    common = [f"{k}={toml_value(v)}" for k, v in _flatten(raw.get("set", {}), f"sweep file {path}: [set]").items()]
    common += list(extra or [])
    out_dir = Path(out) if out is not None else Path(raw.get("out") or f"results/{path.stem}")
    try:
        base_scene, _ = read_scene_source(base)
    except SceneError as exc:
        raise SweepError(f"sweep file {path}: key base: {exc}") from None
    cases = [_case(i, base, base_scene, common, v) for i, v in enumerate(variations)]
    varied_keys = list(dict.fromkeys(k for c in cases for k in c.varied))
    return Sweep(path=path, base=base, out=out_dir, cases=cases, varied_keys=varied_keys)


def _case(index: int, base: str, base_scene: dict[str, Any], common: list[str], varied: dict[str, Any]) -> Case:
    """One scene; its folder name hashes what the user wrote (the base scene's content and the
    overrides), so it survives a new suture_fem version that adds keys with defaults.
    """
    overrides = tuple(common + [f"{k}={toml_value(v)}" for k, v in varied.items()])
    try:
        scene, error = load_scene(base, list(overrides)), None
    except SceneError as exc:
        scene, error = None, str(exc)
    digest = _short_hash({"base": base_scene, "overrides": overrides})
    return Case(index, varied, overrides, scene, error, f"{index:03d}-{digest}")


def command_of(sweep: Sweep, case: Case) -> str:
    """The ``suture-fem run`` command that solves one case on its own."""
    sets = [a for o in case.overrides for a in ("--set", o)]
    return shlex.join(["suture-fem", "run", sweep.base, *sets, "--out", str(sweep.out / case.name)])


# ---------------------------------------------------------------------------------------------
# Folders


def read_status(folder: Path) -> dict[str, Any] | None:
    try:
        return read_json(folder / "status.json")
    except (OSError, ValueError):
        return None


def finished_scenes(out: Path) -> dict[str, str]:
    """Folder name -> status of every scene folder under ``out`` that has a status.json."""
    found: dict[str, str] = {}
    if out.is_dir():
        for folder in sorted(out.iterdir()):
            status = read_status(folder) if folder.is_dir() and not folder.name.startswith(".") else None
            if status is not None:
                found[folder.name] = status.get("status", "error")
    return found


def _fresh_folder(folder: Path) -> None:
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)


def _publish(staging: Path, final: Path, status: dict[str, Any]) -> None:
    """Write status.json into the staging folder and rename it into place (replacing an old one)."""
    write_json(staging / "status.json", status)
    if final.exists():
        old = final.with_name(f".{final.name}.old")
        shutil.rmtree(old, ignore_errors=True)
        os.replace(final, old)
        os.replace(staging, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(staging, final)


# ---------------------------------------------------------------------------------------------
# Solving


@dataclass
class Outcome:
    status: str
    exit_code: int
    message: str
    alone: bool = False  # an unexpected exception, possibly on this rank only


def _solve(case: Case, staging: Path, group: Any) -> Outcome:
    from suture_fem.pipeline import run_scene  # imported on every rank by solve_sweep already

    if case.scene is None:
        return Outcome("invalid", SceneError.exit_code, case.error or "")
    try:
        run_scene(case.scene, staging, group)
        return Outcome("converged", 0, "")
    except SolveStopped as exc:
        return Outcome("stopped", exc.exit_code, str(exc))
    except SutureFemError as exc:  # raised on every rank of the group (collective by construction)
        return Outcome("error", exc.exit_code, str(exc))
    except Exception as exc:  # noqa: BLE001 (recorded; the sweep goes on)
        log.error("scene %s: unexpected %s on group rank %d:\n%s", case.name, type(exc).__name__, group.rank,
                  traceback.format_exc())
        return Outcome("error", 1, f"{type(exc).__name__}: {exc}", alone=True)


def _agree(ctl: Any, world: Any, mine: Outcome, what: str) -> Outcome:
    """The group's outcome, once every rank of the group has one (collective on ``ctl``).

    A rank whose exception may have been its own waits at most STRAGGLER_TIMEOUT_S for the others,
    which may be stuck in a collective call of the solve; then it aborts every rank of the job.
    """
    if not wait(ctl.Ibarrier(), STRAGGLER_TIMEOUT_S if mine.alone else None):
        log.error("%s failed on one rank while the rest of its group went on; aborting all ranks (finished "
                  "scenes are kept: run the same command again to resume)", what)
        world.Abort(1)
    outcomes = ctl.allgather(mine)
    return next((o for o in outcomes if o.status != "converged"), outcomes[0])


def _case_status(sweep: Sweep, case: Case, outcome: Outcome, previous: dict[str, Any] | None,
                 group: Any, group_index: int, seconds: float) -> dict[str, Any]:
    return {
        "index": case.index,
        "name": case.name,
        "status": outcome.status,
        "exit_code": outcome.exit_code,
        "message": outcome.message,
        "varied": case.varied,
        "overrides": list(case.overrides),
        "command": command_of(sweep, case),
        "ranks": group.size,
        "group": group_index,
        "wall_time_s": round(seconds, 3),
        "finished_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "host": platform.node(),
        "solve_count": (previous or {}).get("solve_count", 0) + int(case.scene is not None),
    }


def run_case(sweep: Sweep, case: Case, group: Any, ctl: Any, world: Any, group_index: int) -> str:
    """Solve one case on a group and publish its folder; returns its status (collective on the group)."""
    final = sweep.out / case.name
    staging = sweep.out / f".{case.name}.partial"
    on_root(ctl, f"preparing {staging}", _fresh_folder, staging)
    t0 = time.perf_counter()
    outcome = _agree(ctl, world, _solve(case, staging, group), f"scene {case.name}")
    seconds = time.perf_counter() - t0
    previous = read_status(final) if group.rank == 0 else None
    status = _case_status(sweep, case, outcome, previous, group, group_index, seconds)
    on_root(ctl, f"recording scene {case.name}", _publish, staging, final, status)
    varied = ", ".join(f"{k}={toml_value(v)}" for k, v in case.varied.items()) or "the base scene"
    detail = f": {outcome.message}" if outcome.message else ""
    log.info("scene %s (%s): %s in %.1f s%s", case.name, varied, outcome.status, seconds, detail)
    return outcome.status


class _Counter:
    """The next scene to take, shared by all groups: an integer in an MPI window on world rank 0."""

    def __init__(self, world: Any):
        from mpi4py import MPI

        self.MPI = MPI
        self.win = MPI.Win.Allocate(8 if world.rank == 0 else 0, 8, comm=world)
        if world.rank == 0:
            self.win.Lock(0)
            self.win.Put(bytearray(8), 0)
            self.win.Unlock(0)
        world.Barrier()

    def take(self) -> int:
        one, got = np.ones(1, dtype=np.int64), np.zeros(1, dtype=np.int64)
        self.win.Lock(0, self.MPI.LOCK_SHARED)
        self.win.Fetch_and_op(one, got, 0, 0, self.MPI.SUM)
        self.win.Unlock(0)
        return int(got[0])

    def free(self) -> None:
        self.win.Free()


def solve_sweep(sweep: Sweep, world: Any, ranks_per_scene: int, redo: str | None, schedule: str) -> dict[str, Any]:
    """Solve the cases that are not finished yet (collective on ``world``); returns this run's record."""
    k = ranks_per_scene
    if k < 1 or world.size % k:
        raise SweepError(f"--ranks-per-scene {k}: expected a divisor of the number of MPI ranks ({world.size})")
    # Importing dolfinx initialises PETSc, which is collective on the world: every rank does it now,
    # also those of a group that will get no scene to solve.
    import suture_fem.pipeline  # noqa: F401
    t_start = time.perf_counter()
    on_root(world, f"creating {sweep.out}", sweep.out.mkdir, parents=True, exist_ok=True)
    done = world.bcast(finished_scenes(sweep.out) if world.rank == 0 else None, root=0)
    keep = {None: FINISHED, "all": (), "failed": ("converged",)}[redo]
    todo = [c for c in sweep.cases if done.get(c.name) not in keep]
    skipped = [c.name for c in sweep.cases if done.get(c.name) in keep]
    n_groups = world.size // k
    group_index = world.rank // k
    group = world.Split(group_index, world.rank)
    ctl = group.Dup()  # the sweep's own messages never mix with the solve's collectives
    _log_per_group(group_index, group.rank == 0)
    if world.rank == 0:
        log.info("%d scenes: %d finished before, %d to solve on %d group(s) of %d rank(s), %s schedule; out %s",
                 len(sweep.cases), len(skipped), len(todo), n_groups, k, schedule, sweep.out)
    solved: list[str] = []
    counter = _Counter(world) if schedule == "dynamic" else None
    try:
        if counter is None:
            for case in todo[group_index::n_groups]:
                run_case(sweep, case, group, ctl, world, group_index)
                solved.append(case.name)
        else:
            while True:
                i = ctl.bcast(counter.take() if group.rank == 0 else None, root=0)
                if i >= len(todo):
                    break
                run_case(sweep, todo[i], group, ctl, world, group_index)
                solved.append(todo[i].name)
    except SutureFemError as exc:  # e.g. a folder that cannot be written: the other groups must stop too
        log.error("group %d: %s; aborting all ranks (finished scenes are kept)", group_index, exc)
        if world.size > 1:
            world.Abort(exc.exit_code)
        raise
    wait(world.Ibarrier())  # groups that finish early wait here without spinning
    if counter is not None:
        counter.free()
    solved_by_group = world.gather(solved if group.rank == 0 else [], root=0)
    ctl.Free()
    group.Free()
    return {
        "solved": sorted(n for names in (solved_by_group or []) for n in names),
        "skipped": skipped,
        "mpi_ranks": world.size,
        "ranks_per_scene": k,
        "groups": n_groups,
        "schedule": schedule,
        "wall_time_s": round(time.perf_counter() - t_start, 3),
        "finished_at": datetime.now(UTC).isoformat(timespec="seconds"),
    }


class _SweepLogFilter(logging.Filter):
    """Group leaders show the sweep's lines and warnings; every rank shows errors."""

    def __init__(self, leader: bool, verbose: bool):
        super().__init__()
        self.leader, self.verbose = leader, verbose

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno >= logging.ERROR:
            return True
        return self.leader and (self.verbose or record.name == log.name or record.levelno >= logging.WARNING)


def _log_per_group(group_index: int | None, leader: bool) -> None:
    root = logging.getLogger("suture_fem")
    label = "" if group_index is None else f" [group {group_index}]"
    for handler in root.handlers:
        handler.filters = [_SweepLogFilter(leader, root.level <= logging.DEBUG)]
        handler.setFormatter(logging.Formatter(f"suture-fem{label}: %(message)s"))


# ---------------------------------------------------------------------------------------------
# Summary


def _dig(data: dict[str, Any] | None, dotted: str) -> Any:
    node: Any = data
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return None
        node = node[part]
    return node


def summary_rows(sweep: Sweep) -> list[dict[str, Any]]:
    """One row per case, read from its folder ("pending" where there is none yet)."""
    rows = []
    for case in sweep.cases:
        folder = sweep.out / case.name
        status = read_status(folder)
        try:
            results = read_json(folder / "results.json")
        except (OSError, ValueError):
            results = None
        row: dict[str, Any] = {"index": case.index, "name": case.name,
                               "status": status["status"] if status else "pending"}
        row.update({key: case.varied.get(key) for key in sweep.varied_keys})
        row.update({col: _dig(results, col) for col in RESULT_COLUMNS})
        row.update({col: (status or {}).get(col) for col in STATUS_COLUMNS})
        rows.append(row)
    return rows


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, (list, dict, bool)):
        return toml_value(value)
    return str(value)


def write_summary(sweep: Sweep, last_run: dict[str, Any] | None = None) -> dict[str, Any]:
    """Write OUT/summary.{json,csv,md} from the scene folders (and OUT/last_run.json); returns the JSON."""
    rows = summary_rows(sweep)
    columns = list(rows[0]) if rows else []
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    data = {"sweep": str(sweep.path), "base": sweep.base, "out": str(sweep.out), "scenes": len(rows),
            "counts": counts, "columns": columns, "rows": rows}
    write_json(sweep.out / "summary.json", data)
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    writer.writerows([_cell(row[c]) for c in columns] for row in rows)
    write_text(sweep.out / "summary.csv", buf.getvalue())
    md = [f"# Sweep {sweep.path.name}: {len(rows)} scenes of {sweep.base}", "",
          ", ".join(f"{n} {s}" for s, n in sorted(counts.items())), "",
          "| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
    md += ["| " + " | ".join(_cell(row[c]).replace("|", "\\|").replace("\n", " ") for c in columns) + " |"
           for row in rows]
    write_text(sweep.out / "summary.md", "\n".join(md) + "\n")
    if last_run is not None:
        write_json(sweep.out / "last_run.json", last_run)
    return data


# ---------------------------------------------------------------------------------------------
# Command line


def register(subparsers: Any, scene_args: Any) -> None:
    p = subparsers.add_parser("sweep", help="solve many scenes (a grid or a list of overrides), shared among "
                              "groups of MPI ranks; see docs/slurm.md")
    p.add_argument("sweep", help="a sweep TOML file")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scene key in every scene of the sweep (repeatable)")
    p.add_argument("--out", default=None, help="output folder (default: the sweep file's `out`, else results/<name>)")
    p.add_argument("--ranks-per-scene", type=int, default=1, metavar="K",
                   help="MPI ranks that solve each scene together (must divide the number of ranks; default 1)")
    p.add_argument("--schedule", choices=("static", "dynamic"), default="static",
                   help="static: scenes dealt round-robin to the groups; dynamic: a group takes the next scene "
                   "when it is free (default static)")
    p.add_argument("--redo", nargs="?", const="all", choices=("all", "failed"), default=None,
                   help="solve finished scenes again (all, or only those that did not converge)")
    p.add_argument("--fields", action="store_true", help="also write XDMF fields of every scene")
    p.add_argument("--summary-only", action="store_true", help="rebuild the summary from the folders; solve nothing")
    p.add_argument("--list", action="store_true", help="print the scenes, their folders and status; solve nothing")
    p.set_defaults(handler=sweep_command)


def sweep_command(args: argparse.Namespace, comm: Any) -> int:
    _log_per_group(None, comm.rank == 0)  # per-scene solver chatter stays out of a sweep's log (-v shows it)
    extra = list(args.overrides) + (["output.fields=true"] if args.fields else [])
    sweep = load_sweep(args.sweep, extra, args.out)
    if args.list:
        if comm.rank == 0:
            done = finished_scenes(sweep.out)
            for case in sweep.cases:
                state = done.get(case.name, "invalid: " + case.error if case.error else "pending")
                print(f"{case.name}  {state:10s}  {' '.join(case.overrides)}")
        return 0
    last_run = None if args.summary_only else solve_sweep(sweep, comm, args.ranks_per_scene, args.redo,
                                                          args.schedule)
    data = on_root(comm, f"writing the summary in {sweep.out}", write_summary, sweep, last_run)
    data = comm.bcast(data, root=0)
    counts = data["counts"]
    if comm.rank == 0:
        ran = f"solved {len(last_run['solved'])}, skipped {len(last_run['skipped'])}; " if last_run else ""
        print(f"suture-fem: sweep {sweep.path.name}: {ran}" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
              + f"; summary in {sweep.out / 'summary.md'} (.json, .csv)")
    if counts.get("converged", 0) == len(sweep.cases):
        return 0
    return SolveStopped.exit_code
