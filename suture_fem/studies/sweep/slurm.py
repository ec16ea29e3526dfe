"""A sweep as a Slurm job array: one array task per scene, each on its own ``srun`` of K ranks.

``suture-fem sweep FILE --slurm`` expands the sweep, picks the scenes that are neither finished nor
queued nor running, and submits them with ``sbatch --array=I,J,...`` (the array index is the scene's
position in the sweep) plus one job that rebuilds the summary when the array has ended
(``--dependency=afterany``). Each task runs ``srun --mpi=pmix python -P -m suture_fem.cli sweep
FILE --slurm-task I``, which solves scene I exactly as a local sweep would (:mod:`.task`). The sweep
folder stays the record: ``OUT/slurm/jobs.json`` lists the submissions, ``OUT/slurm/*.log`` the task
logs, and ``--status`` reads the folders and asks ``squeue`` about the submitted jobs.

sbatch is called with an argument list, never through a shell; the batch script holds only the
interpreter, the sweep file, the output folder and the command line's ``--set`` values, each quoted.
Sweep files cannot name sbatch options: those come from the command line or an options file, and
are checked here first (see :func:`check_sbatch_options`).
"""

from __future__ import annotations

import hashlib
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from suture_fem.studies.sweep.folders import FINISHED, scene_busy
from suture_fem.studies.sweep.plan import Sweep, SweepError
from suture_fem.support.errors import SutureFemError
from suture_fem.support.io import read_json, write_json, write_text

#: sbatch options the submission sets itself; an extra option may not change them.
RESERVED = {"--array": "-a", "--ntasks": "-n", "--output": "-o", "--error": "-e", "--wrap": None,
            "--parsable": None, "--partition": "-p", "--time": "-t", "--dependency": "-d"}
_LONG = re.compile(r"--[a-z][a-z0-9-]*")
_TIME = re.compile(r"(\d+-)?\d+(:\d{1,2}){0,2}|UNLIMITED|INFINITE")
_PARTITION = re.compile(r"[A-Za-z0-9_.-]+(,[A-Za-z0-9_.-]+)*")
_MPI = re.compile(r"[a-z0-9_]+")


@dataclass
class SlurmOptions:
    """What a user chooses for the job array (all checked by :func:`check_options`)."""

    ranks_per_scene: int = 1
    partition: str | None = None
    time: str | None = None
    mpi: str = "pmix"
    max_running: int | None = None
    extra: list[str] = field(default_factory=list)


def check_sbatch_options(tokens: list[str], where: str) -> list[str]:
    """Extra sbatch options as argument tokens; SweepError (exit 2) names the first bad one.

    Each option is ``--name=value``, ``--name value``, ``--flag``, ``-x value`` or ``-xvalue``; no
    control characters; not one the submission sets itself (``RESERVED``).
    """
    reserved = set(RESERVED) | {s for s in RESERVED.values() if s}
    expect_value = False
    for tok in tokens:
        if any(ord(c) < 32 or ord(c) == 127 for c in tok):
            raise SweepError(f"{where}: sbatch option {tok!r}: control characters are not allowed")
        if tok.startswith("--"):
            name = tok.split("=", 1)[0]
            if not _LONG.fullmatch(name):
                raise SweepError(f"{where}: sbatch option {tok!r}: expected --name=value with a lower-case name")
            expect_value = "=" not in tok
        elif tok.startswith("-") and len(tok) >= 2 and tok[1].isalpha():
            name = tok[:2]
            expect_value = len(tok) == 2
        elif expect_value:
            expect_value = False
            continue
        else:
            raise SweepError(f"{where}: {tok!r} is not an sbatch option (expected --name=value or -x value)")
        if name in reserved:
            raise SweepError(f"{where}: sbatch option {name} is set by suture-fem sweep --slurm itself "
                             "(use --partition, --time, --ranks-per-scene or --max-running)")
    return list(tokens)


def read_sbatch_file(path: str) -> list[str]:
    """The sbatch options in a file: one or more per line, ``#SBATCH`` prefixes allowed, ``#`` comments skipped."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepError(f"--sbatch-file {path}: cannot be read ({exc})") from None
    tokens: list[str] = []
    for n, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if line.startswith("#SBATCH"):
            line = line[len("#SBATCH"):]
        elif line.startswith("#") or not line:
            continue
        try:
            tokens += shlex.split(line)
        except ValueError as exc:
            raise SweepError(f"--sbatch-file {path}, line {n}: {exc}") from None
    return check_sbatch_options(tokens, f"--sbatch-file {path}")


def check_options(opts: SlurmOptions) -> SlurmOptions:
    """The options, or SweepError (exit 2) naming the first bad one and what is allowed."""
    if opts.ranks_per_scene < 1:
        raise SweepError(f"--ranks-per-scene {opts.ranks_per_scene}: expected an integer >= 1")
    if opts.partition is not None and not _PARTITION.fullmatch(opts.partition):
        raise SweepError(f"--partition {opts.partition!r}: expected a partition name (letters, digits, _ . -), "
                         "or several separated by commas")
    if opts.time is not None and not _TIME.fullmatch(opts.time):
        raise SweepError(f"--time {opts.time!r}: expected minutes, MM:SS, HH:MM:SS, D-HH, D-HH:MM or D-HH:MM:SS")
    if not _MPI.fullmatch(opts.mpi):
        raise SweepError(f"--mpi {opts.mpi!r}: expected a Slurm MPI plugin name such as pmix (srun --mpi=list)")
    if opts.max_running is not None and opts.max_running < 1:
        raise SweepError(f"--max-running {opts.max_running}: expected an integer >= 1")
    return opts


def plan_digest(sweep: Sweep) -> str:
    """A hash of the sweep's scene folders, in order: a task refuses to run when the sweep file changed."""
    return hashlib.sha256("\n".join(c.name for c in sweep.cases).encode()).hexdigest()[:12]


def _tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        raise SutureFemError(f"{name} not found: --slurm and --status need Slurm's commands on the PATH")
    return path


def task_script(sweep: Sweep, opts: SlurmOptions, cli_args: list[str]) -> str:
    """The batch script of every array task: srun of this interpreter on the task's scene (every word quoted)."""
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "sweep", str(sweep.path.resolve()),
           "--out", str(sweep.out.resolve()), *cli_args, "--plan", plan_digest(sweep)]
    return ("#!/bin/sh\n# written by suture-fem sweep --slurm: scene number $SLURM_ARRAY_TASK_ID of the sweep\n"
            "export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1\n"
            f"exec srun --mpi={opts.mpi} {shlex.join(cmd)} --slurm-task \"$SLURM_ARRAY_TASK_ID\"\n")


def summary_script(sweep: Sweep, cli_args: list[str]) -> str:
    """The batch script of the job that rebuilds the summary once the array has ended."""
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "sweep", str(sweep.path.resolve()),
           "--out", str(sweep.out.resolve()), *cli_args, "--summary-only"]
    return ("#!/bin/sh\n# written by suture-fem sweep --slurm: the summary, once the array has ended\n"
            f"exec {shlex.join(cmd)}\n")


def _sbatch(args: list[str], script: Path) -> str:
    proc = subprocess.run([_tool("sbatch"), "--parsable", *args, str(script)], capture_output=True, text=True)
    if proc.returncode != 0:
        lines = (proc.stderr or proc.stdout).strip().splitlines() or [f"exit code {proc.returncode}"]
        raise SweepError(f"sbatch refused the job: {lines[-1]}")
    return proc.stdout.strip().split(";")[0]


def submit(sweep: Sweep, opts: SlurmOptions, cli_args: list[str], redo: str | None) -> dict[str, Any]:
    """Submit the scenes still to solve as one job array and a summary job; returns the submission record.

    ``cli_args`` are the sweep options every task repeats (``--set``, ``--fields``); ``redo`` as for a sweep.
    Nothing is submitted (and None returned in ``array_job``) when no scene is left.
    """
    sbatch = _tool("sbatch")
    states = scene_states(sweep)
    keep = {None: FINISHED, "all": (), "failed": ("converged",)}[redo]
    todo = [c for c in sweep.cases if states[c.name] not in keep and states[c.name] not in ("queued", "running")]
    record: dict[str, Any] = {"submitted_at": datetime.now(UTC).isoformat(timespec="seconds"),
                              "scenes": {str(c.index): c.name for c in todo}, "array_job": None}
    if not todo:
        return record
    folder = sweep.out / "slurm"
    write_text(folder / "task.sh", task_script(sweep, opts, cli_args + ["--redo", redo] * bool(redo)))
    write_text(folder / "summary.sh", summary_script(sweep, cli_args))
    common = [f"--partition={opts.partition}"] * bool(opts.partition) + [f"--time={opts.time}"] * bool(opts.time)
    common += [f"--chdir={Path.cwd()}", *opts.extra]
    array = ",".join(str(c.index) for c in todo) + (f"%{opts.max_running}" if opts.max_running else "")
    name = f"--job-name={sweep.path.stem}"
    record["array_job"] = _sbatch([name, f"--array={array}", "--nodes=1", f"--ntasks={opts.ranks_per_scene}",
                                   f"--output={folder.resolve()}/%A_%a.log", *common], folder / "task.sh")
    record.update(summary_job=None, ranks_per_scene=opts.ranks_per_scene, plan=plan_digest(sweep), sbatch=sbatch)
    jobs = folder / "jobs.json"
    previous = read_json(jobs) if jobs.exists() else []
    write_json(jobs, previous + [record])  # recorded at once: --status and the next submission know the array
    record["summary_job"] = _sbatch([f"{name}-summary", f"--dependency=afterany:{record['array_job']}", "--ntasks=1",
                                     f"--output={folder.resolve()}/%j-summary.log", *common], folder / "summary.sh")
    write_json(jobs, previous + [record])
    return record


def queued_tasks(out: Path) -> tuple[dict[str, str], str | None]:
    """Scene folder -> Slurm state (PENDING, RUNNING, ...) of the submitted tasks still in the queue.

    Returns the map and, when squeue cannot be asked, why not (the map is then empty).
    """
    jobs_file = out / "slurm" / "jobs.json"
    if not jobs_file.exists():
        return {}, None
    jobs = [j for j in read_json(jobs_file) if j.get("array_job")]
    squeue = shutil.which("squeue")
    if squeue is None or not jobs:
        return {}, None if jobs == [] else "squeue not found"
    # All of this user's tasks, matched here: a job id the controller has forgotten cannot fail the query.
    proc = subprocess.run([squeue, "-h", "-r", "--me", "-o", "%i %T"], capture_output=True, text=True)
    if proc.returncode != 0:
        return {}, (proc.stderr.strip().splitlines() or ["squeue failed"])[-1]
    names = {(j["array_job"], i): n for j in jobs for i, n in j["scenes"].items()}
    found: dict[str, str] = {}
    for line in proc.stdout.split("\n"):
        task, _, state = line.strip().partition(" ")
        job, _, index = task.partition("_")
        if (job, index) in names:
            found[names[job, index]] = state
    return found, None


def scene_states(sweep: Sweep) -> dict[str, str]:
    """Every scene's state: its folder's status, else running (its lock is held), queued (in squeue) or pending."""
    from suture_fem.studies.sweep.folders import finished_scenes

    done = finished_scenes(sweep.out)
    queue, _ = queued_tasks(sweep.out)
    states = {}
    for case in sweep.cases:
        if scene_busy(sweep.out, case.name) or queue.get(case.name) in ("RUNNING", "COMPLETING"):
            states[case.name] = "running"
        elif case.name in queue:
            states[case.name] = "queued"
        else:
            states[case.name] = done.get(case.name, "pending")
    return states
