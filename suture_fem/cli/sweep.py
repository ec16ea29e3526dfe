"""``suture-fem sweep SWEEP.toml``: many scenes, shared among groups of MPI ranks (see docs/slurm.md).

Argument parsing and printing only; the study is :mod:`suture_fem.studies.sweep`. Exit code: 0 when
every scene converged, 3 when the sweep finished with failed scenes, 2 for a bad sweep file or arguments.
"""

from __future__ import annotations

import argparse
from typing import Any

from suture_fem.studies.sweep import finished_scenes, load_sweep, log_per_group, run_sweep
from suture_fem.studies.sweep.plan import SweepError
from suture_fem.support.errors import SolveStopped


def register(subparsers: Any, scene_args: Any) -> None:
    """Add the ``sweep`` subcommand."""
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
    _slurm_args(p)
    p.set_defaults(handler=sweep_command)


def _slurm_args(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("Slurm", "submit the sweep as a job array, one task of K ranks per scene (docs/slurm.md)")
    g.add_argument("--slurm", action="store_true", help="submit the scenes not finished yet (sbatch) and return")
    g.add_argument("--status", action="store_true",
                   help="print every scene's state: its folder's status, or running, queued (Slurm) or pending")
    g.add_argument("--partition", default=None, help="Slurm partition (default: the cluster's default)")
    g.add_argument("--time", default=None, metavar="LIMIT", help="time limit of each task, e.g. 30, 1:30:00, 1-12")
    g.add_argument("--mpi", default="pmix", metavar="TYPE", help="srun --mpi type that starts the ranks (default pmix)")
    g.add_argument("--max-running", type=int, default=None, metavar="M", help="at most M tasks at a time")
    g.add_argument("--sbatch", action="append", default=[], metavar="OPTIONS",
                   help="more sbatch options, e.g. --sbatch='--mem-per-cpu=2G --account=proj' (repeatable)")
    g.add_argument("--sbatch-file", default=None, metavar="FILE",
                   help="more sbatch options from a file, one or more per line (#SBATCH prefixes allowed)")
    g.add_argument("--slurm-task", type=int, default=None, help=argparse.SUPPRESS)
    g.add_argument("--plan", default=None, help=argparse.SUPPRESS)


def sweep_command(args: argparse.Namespace, comm: Any) -> int:
    """List the scenes, or solve the sweep and print the counts; exit 0 only when every scene converged."""
    log_per_group(None, comm.rank == 0)  # per-scene solver chatter stays out of a sweep's log (-v shows it)
    extra = list(args.overrides) + (["output.fields=true"] if args.fields else [])
    modes = [m for m in ("slurm", "status", "list", "summary_only") if getattr(args, m)]
    if len(modes) > 1:
        raise SweepError(f"give at most one of --{' --'.join(m.replace('_', '-') for m in modes)}")
    if args.slurm or args.status or args.slurm_task is not None:
        from suture_fem.cli.sweep_slurm import slurm_command

        return slurm_command(args, comm, extra)
    sweep = load_sweep(args.sweep, extra, args.out)
    if args.list:
        if comm.rank == 0:
            done = finished_scenes(sweep.out)
            for case in sweep.cases:
                state = done.get(case.name, "invalid: " + case.error if case.error else "pending")
                print(f"{case.name}  {state:10s}  {' '.join(case.overrides)}")
        return 0
    data, last_run = run_sweep(sweep, comm, args.ranks_per_scene, args.redo, args.schedule, args.summary_only)
    counts = data["counts"]
    if comm.rank == 0:
        ran = f"solved {len(last_run['solved'])}, skipped {len(last_run['skipped'])}; " if last_run else ""
        print(f"suture-fem: sweep {sweep.path.name}: {ran}" + ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
              + f"; summary in {sweep.out / 'summary.md'} (.json, .csv)")
    if counts.get("converged", 0) == len(sweep.cases):
        return 0
    return SolveStopped.exit_code
