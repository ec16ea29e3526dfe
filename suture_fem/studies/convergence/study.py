"""The whole ledger study: solve (or reuse) a ladder's rungs, analyse them and write the ledger."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from suture_fem.studies.convergence.analysis import analyse
from suture_fem.studies.convergence.ladder import Ladder, Rung, solve_ladder
from suture_fem.studies.convergence.report import write_ledger


def run_ledger(ladder: Ladder, out: Path, title: str, comm: Any, inprocess: bool = False, redo: bool = False,
               report_only: bool = False) -> tuple[list[Rung], dict[str, Any]]:
    """Solve every rung of ``ladder`` into ``out/rungs``, analyse them and write the ledger files (rank 0).

    Returns the rungs and the analysis (per force and quantity). ``inprocess``, ``redo`` and
    ``report_only`` are those of :func:`~suture_fem.studies.convergence.ladder.solve_ladder`.
    """
    rungs = solve_ladder(ladder, out, comm, inprocess, redo, report_only)
    analysis = analyse(rungs, ladder.forces)
    if comm.rank == 0:
        write_ledger(out, title, ladder, rungs, analysis)
    return rungs, analysis
