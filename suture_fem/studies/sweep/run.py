"""Solving a sweep: groups of MPI ranks, each scene on one group, the outcome agreed and published.

Under ``mpirun -n N ... --ranks-per-scene K`` the world communicator is split into N/K groups
(``comm.Split``); each scene is solved by one group on the group's communicator. Scenes are dealt
round-robin (``--schedule static``) or taken one at a time from a counter in an MPI window
(``--schedule dynamic``: a group that finishes early takes the next scene). A scene that fails
records its diagnosis and the sweep goes on.
"""

from __future__ import annotations

import logging
import os
import platform
import time
import traceback
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.studies.sweep.folders import (
    FINISHED,
    finished_scenes,
    fresh_folder,
    publish,
    read_status,
    release_lock,
    take_lock,
)
from suture_fem.studies.sweep.plan import Case, Sweep, SweepError, command_of, toml_value
from suture_fem.studies.sweep.summary import write_summary
from suture_fem.support.errors import SceneError, SolveStopped, SutureFemError
from suture_fem.support.parallel import on_root, wait

log = logging.getLogger("suture_fem.sweep")

#: How long a rank that failed alone waits for the rest of its group before aborting every rank
#: (the others may be blocked in a collective call that will never complete).
STRAGGLER_TIMEOUT_S = 120.0


@dataclass
class Outcome:
    """How a scene ended on one rank: its status, exit code and message.

    ``alone`` marks an unexpected exception, which may have been raised on this rank only.
    """

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
        "pid": os.getpid(),
        "solve_count": (previous or {}).get("solve_count", 0) + int(case.scene is not None),
    }


def run_case(sweep: Sweep, case: Case, group: Any, ctl: Any, world: Any, group_index: int) -> str:
    """Solve one case on a group and publish its folder; returns its status (collective on the group)."""
    final = sweep.out / case.name
    staging = sweep.out / f".{case.name}.partial"
    on_root(ctl, f"preparing {staging}", fresh_folder, staging)
    t0 = time.perf_counter()
    outcome = _agree(ctl, world, _solve(case, staging, group), f"scene {case.name}")
    seconds = time.perf_counter() - t0
    previous = read_status(final) if group.rank == 0 else None
    status = _case_status(sweep, case, outcome, previous, group, group_index, seconds)
    on_root(ctl, f"recording scene {case.name}", publish, staging, final, status)
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
    log_per_group(group_index, group.rank == 0)
    if world.rank == 0:
        log.info("%d scenes: %d finished before, %d to solve on %d group(s) of %d rank(s), %s schedule; out %s",
                 len(sweep.cases), len(skipped), len(todo), n_groups, k, schedule, sweep.out)
    counter = _Counter(world) if schedule == "dynamic" else None
    try:
        solved = _solve_share(sweep, todo, group, ctl, world, group_index, counter)
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


def _solve_share(sweep: Sweep, todo: list[Case], group: Any, ctl: Any, world: Any, group_index: int,
                 counter: _Counter | None) -> list[str]:
    """Solve this group's share of ``todo``; returns the names solved (collective on the group).

    Static schedule (no ``counter``): every n-th case, n the number of groups. Dynamic: the group
    leader takes the next case from the shared counter until none is left.
    """
    solved: list[str] = []
    if counter is None:
        n_groups = world.size // group.size
        for case in todo[group_index::n_groups]:
            run_case(sweep, case, group, ctl, world, group_index)
            solved.append(case.name)
        return solved
    while True:
        i = ctl.bcast(counter.take() if group.rank == 0 else None, root=0)
        if i >= len(todo):
            return solved
        run_case(sweep, todo[i], group, ctl, world, group_index)
        solved.append(todo[i].name)


class _SweepLogFilter(logging.Filter):
    """Group leaders show the sweep's lines and warnings; every rank shows errors."""

    def __init__(self, leader: bool, verbose: bool):
        super().__init__()
        self.leader, self.verbose = leader, verbose

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno >= logging.ERROR:
            return True
        return self.leader and (self.verbose or record.name == log.name or record.levelno >= logging.WARNING)


def log_per_group(group_index: int | None, leader: bool) -> None:
    """Label the log lines with the group (``None``: no label) and show them on group leaders only.

    Per-scene solver chatter stays out of a sweep's log unless the log level is DEBUG (``-v``).
    """
    root = logging.getLogger("suture_fem")
    label = "" if group_index is None else f" [group {group_index}]"
    for handler in root.handlers:
        handler.filters = [_SweepLogFilter(leader, root.level <= logging.DEBUG)]
        handler.setFormatter(logging.Formatter(f"suture-fem{label}: %(message)s"))


def run_sweep(sweep: Sweep, world: Any, ranks_per_scene: int = 1, redo: str | None = None,
              schedule: str = "static", summary_only: bool = False) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """Solve what is not finished (nothing with ``summary_only``), then write the summary (collective).

    Args:
        sweep: the expanded sweep file.
        world: the communicator split into groups of ``ranks_per_scene`` ranks.
        ranks_per_scene: ranks that solve each scene together; must divide ``world.size``.
        redo: None (skip finished scenes), "all" or "failed" (solve again those that did not converge).
        schedule: "static" (round-robin) or "dynamic" (a free group takes the next scene).
        summary_only: rebuild the summary from the folders without solving.

    Returns:
        (summary.json's content, this run's record or None), the same on every rank.
    """
    if ranks_per_scene < 1 or world.size % ranks_per_scene:  # before the folder is made
        raise SweepError(f"--ranks-per-scene {ranks_per_scene}: expected a divisor of the number of MPI ranks "
                         f"({world.size})")
    lock = on_root(world, f"locking {sweep.out}", take_lock, sweep.out)  # one sweep per folder at a time
    try:
        last_run = None if summary_only else solve_sweep(sweep, world, ranks_per_scene, redo, schedule)
        data = on_root(world, f"writing the summary in {sweep.out}", write_summary, sweep, last_run)
    finally:
        if lock is not None:
            release_lock(lock, sweep.out)
    return world.bcast(data, root=0), last_run
