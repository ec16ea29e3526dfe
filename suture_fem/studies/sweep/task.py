"""One Slurm array task: one scene of a sweep, solved by every rank of the task's ``srun``.

The task solves its scene exactly as a local sweep's group would (:func:`run_case`: staging folder,
status.json, the folder renamed into place), under two locks: the sweep folder shared (a local sweep
holds it exclusively) and the scene exclusive (two tasks never solve one scene). A scene that is
already finished is skipped unless ``--redo``; a task that is cancelled or killed leaves only its
hidden staging folder, so the scene is still to do and the next submission solves it again.
"""

from __future__ import annotations

import logging
from typing import Any

from suture_fem.studies.sweep.folders import FINISHED, read_status, release_task_locks, take_task_locks
from suture_fem.studies.sweep.plan import Sweep, SweepError
from suture_fem.studies.sweep.run import log_per_group, run_case
from suture_fem.studies.sweep.slurm import plan_digest
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem.sweep")


def run_task(sweep: Sweep, world: Any, index: int, plan: str, redo: str | None) -> str:
    """Solve scene ``index`` on ``world`` unless it is finished; returns its status (collective).

    Raises SweepError when the sweep file changed since the submission (``plan`` differs), the
    index is out of range, or a lock is held.
    """
    if plan != plan_digest(sweep):
        raise SweepError(f"sweep file {sweep.path} changed since these tasks were submitted (its scenes differ); "
                         "submit it again with --slurm")
    if not 0 <= index < len(sweep.cases):
        raise SweepError(f"--slurm-task {index}: expected 0 to {len(sweep.cases) - 1}")
    case = sweep.cases[index]
    import suture_fem.pipeline  # noqa: F401  (PETSc's initialisation is collective: every rank now)

    locks = on_root(world, f"locking scene {case.name}", take_task_locks, sweep.out, case.name)
    try:
        previous = read_status(sweep.out / case.name) if world.rank == 0 else None
        keep = {None: FINISHED, "all": (), "failed": ("converged",)}[redo]
        status = world.bcast((previous or {}).get("status") if world.rank == 0 else None, root=0)
        if status in keep:
            if world.rank == 0:
                log.info("scene %s: %s before; skipped", case.name, status)
            return status
        log_per_group(index, world.rank == 0)
        ctl = world.Dup()
        try:
            return run_case(sweep, case, world, ctl, world, index)
        finally:
            ctl.Free()
    finally:
        if locks is not None:
            release_task_locks(sweep.out, case.name, locks)
