"""``suture-fem sweep FILE --slurm | --status``: a sweep as a Slurm job array, and every scene's state.

Argument checking and printing only; the submission is :mod:`suture_fem.studies.sweep.slurm`, one
array task :mod:`suture_fem.studies.sweep.task`. Bad options exit 2 before anything is submitted
or written.
"""

from __future__ import annotations

import argparse
import shlex
from collections import Counter
from typing import Any

from suture_fem.studies.sweep import load_sweep
from suture_fem.studies.sweep.plan import SweepError
from suture_fem.studies.sweep.slurm import (
    SlurmOptions,
    check_options,
    check_sbatch_options,
    queued_tasks,
    read_sbatch_file,
    scene_states,
    submit,
)
from suture_fem.support.errors import SolveStopped


def _options(args: argparse.Namespace) -> SlurmOptions:
    extra: list[str] = []
    for text in args.sbatch:
        try:
            extra += check_sbatch_options(shlex.split(text), "--sbatch")
        except ValueError as exc:
            raise SweepError(f"--sbatch {text!r}: {exc}") from None
    if args.sbatch_file is not None:
        extra = read_sbatch_file(args.sbatch_file) + extra
    return check_options(SlurmOptions(ranks_per_scene=args.ranks_per_scene, partition=args.partition, time=args.time,
                                      mpi=args.mpi, max_running=args.max_running, extra=extra))


def slurm_command(args: argparse.Namespace, comm: Any, extra: list[str]) -> int:
    """Submit (``--slurm``), report (``--status``) or run one array task (``--slurm-task I``)."""
    if args.slurm_task is not None:
        return _task(args, comm, extra)
    if comm.size > 1:
        raise SweepError("--slurm and --status run on one process (not under mpirun)")
    opts = _options(args) if args.slurm else None
    sweep = load_sweep(args.sweep, extra, args.out)
    if args.status:
        return _status(sweep)
    record = submit(sweep, opts, [a for o in extra for a in ("--set", o)], args.redo)
    if record["array_job"] is None:
        print(f"suture-fem: sweep {sweep.path.name}: nothing to submit (every scene is finished, queued or "
              f"running; --status shows which, --redo solves finished scenes again)")
        return 0
    print(f"suture-fem: sweep {sweep.path.name}: submitted {len(record['scenes'])} of {len(sweep.cases)} scenes as "
          f"job array {record['array_job']} ({opts.ranks_per_scene} rank(s) each), summary job "
          f"{record['summary_job']}; logs in {sweep.out / 'slurm'}; `suture-fem sweep {args.sweep} --status` "
          "shows progress")
    return 0


def _status(sweep: Any) -> int:
    states = scene_states(sweep)
    _, problem = queued_tasks(sweep.out)
    for case in sweep.cases:
        print(f"{case.name}  {states[case.name]:10s}  {' '.join(case.overrides)}")
    counts = Counter(states.values())
    print(f"suture-fem: sweep {sweep.path.name}: {len(sweep.cases)} scenes: "
          + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())) + f" (folder {sweep.out})")
    if problem:
        print(f"suture-fem: the Slurm queue could not be read ({problem}): queued scenes show as pending")
    return 0


def _task(args: argparse.Namespace, comm: Any, extra: list[str]) -> int:
    from suture_fem.studies.sweep.task import run_task

    if args.plan is None:
        raise SweepError("--slurm-task needs --plan (both are written by --slurm)")
    sweep = load_sweep(args.sweep, extra, args.out)
    status = run_task(sweep, comm, args.slurm_task, args.plan, args.redo)
    if comm.rank == 0:
        print(f"suture-fem: sweep {sweep.path.name}: scene {sweep.cases[args.slurm_task].name}: {status}")
    return 0 if status == "converged" else SolveStopped.exit_code
