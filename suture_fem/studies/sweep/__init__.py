"""``suture-fem sweep SWEEP.toml``: many scenes, shared among groups of MPI ranks.

A sweep file names a base scene and what to vary, either as a grid (every combination, the first
key varying slowest) or as an explicit list of override tables (``plan``: the file's format).
Each scene is the base scene with ``--set KEY=VALUE`` overrides (the sweep's ``[set]``, the command
line's ``--set``, then the scene's own), so ``status.json`` records the ``suture-fem run`` command
that reproduces it.

Under ``mpirun -n N ... --ranks-per-scene K`` the world communicator is split into N/K groups
(``comm.Split``); each scene is solved by one group on the group's communicator. Scenes are dealt
round-robin (``--schedule static``) or taken one at a time from a counter in an MPI window
(``--schedule dynamic``: a group that finishes early takes the next scene) (``run``).

Every scene has a folder ``OUT/NNN-HASH`` (position in the sweep, and a hash of the base scene's
content and the scene's overrides). It is filled in a hidden staging
folder and renamed into place when the scene is finished, so it is complete or absent; it holds
``results.json`` (and the fields if asked) and ``status.json``: status (converged, stopped,
invalid, error), exit code, message, the reproducing command, and ``solve_count``. A scene that
fails records its diagnosis and the sweep goes on. Running the same sweep again skips the scenes
whose folder exists (converged, stopped or invalid; an "error" is retried) unless ``--redo``
(``--redo failed``: only the ones that did not converge) (``folders``).

At the end world rank 0 writes ``OUT/summary.{json,csv,md}`` from the folders (``--summary-only``
rebuilds them without solving) and ``OUT/last_run.json`` (what this run solved and skipped) (``summary``).
Exit code: 0 when every scene converged, 3 when the sweep finished with failed scenes, 2 for a
bad sweep file or arguments.

The modules: ``plan`` (the sweep file, its cases and their folder names), ``folders`` (status files,
publishing a finished folder), ``run`` (groups of ranks, scheduling, the outcome every rank of a group
agrees on), ``summary`` (rows, JSON/CSV/Markdown), ``slurm`` (submitting the scenes as a Slurm job array,
``--status``) and ``task`` (one array task: one scene). The names below are the study's public face.
"""

from suture_fem.studies.sweep.folders import FINISHED, finished_scenes, read_status
from suture_fem.studies.sweep.plan import Case, Sweep, SweepError, command_of, load_sweep, toml_value
from suture_fem.studies.sweep.run import log_per_group, run_case, run_sweep, solve_sweep
from suture_fem.studies.sweep.summary import summary_rows, write_summary

__all__ = ["FINISHED", "Case", "Sweep", "SweepError", "command_of", "finished_scenes", "load_sweep", "log_per_group",
           "read_status", "run_case", "run_sweep", "solve_sweep", "summary_rows", "toml_value", "write_summary"]
