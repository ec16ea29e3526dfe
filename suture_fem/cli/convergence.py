"""``suture-fem convergence`` (the accuracy-cost ledger) and ``suture-fem ledger-rung`` (one of its rungs).

    suture-fem convergence SCENE [--set KEY=VALUE ...] [--out DIR] [--degrees 1,2] [--refinements 0,1,2]
                           [--refine all|rim|fillet]
    suture-fem ledger-rung SCENE [--set KEY=VALUE ...] --out DIR

This module parses the arguments and calls the study (:mod:`suture_fem.studies.convergence`); every
rung of a ledger runs ``python -P -m suture_fem.cli ledger-rung`` in its own process unless
``--inprocess`` or mpirun keeps it in this one. Exit codes: 0 every rung converged, 2 a bad scene or
ladder (before any solve), 3 some rung did not converge.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.studies.convergence.ladder import FORMULATION_KEY, LEVEL_NAMES, plan_ladder
from suture_fem.studies.convergence.singular import solve_rung
from suture_fem.studies.convergence.study import run_ledger
from suture_fem.support.errors import SceneError
from suture_fem.support.io import usable_folder


def _int_list(text: str, option: str) -> list[int]:
    try:
        return sorted({int(t) for t in text.split(",") if t.strip()})
    except ValueError:
        raise SceneError(f"{option}: expected a comma-separated list of integers, got {text!r}") from None


def _float_list(text: str) -> list[float]:
    try:
        return sorted({float(t) for t in text.split(",") if t.strip()})
    except ValueError:
        raise SceneError(f"--forces: expected a comma-separated list of forces in N, got {text!r}") from None


def _caps(texts: list[str]) -> dict[int, int]:
    caps = {}
    for text in texts:
        degree, _, level = text.partition("=")
        if not (degree.strip().isdigit() and level.strip().isdigit()):
            raise SceneError(f"--cap {text!r}: expected DEGREE=LEVEL, for example 2=1")
        caps[int(degree)] = int(level)
    return caps


def register(subparsers: Any, scene_args: Any) -> None:
    """Add ``ledger-rung`` and ``convergence`` to the ``suture-fem`` command line."""
    p = subparsers.add_parser("ledger-rung", help="one rung of `convergence`: `run` plus the tissue's maxima away "
                              "from every singular point (results.json, at_forces[].ledger)")
    scene_args(p)
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(handler=rung_main)
    p = subparsers.add_parser("convergence", help="the accuracy-cost ledger: a ladder of refinements and degrees, "
                              "Richardson error estimates, wall time and memory per rung")
    scene_args(p)
    p.add_argument("--out", default=None, help="output folder (default: results/<scene name>-convergence)")
    p.add_argument("--degrees", default="1,2", help="element degrees (default 1,2)")
    p.add_argument("--refinements", default="0,1,2",
                   help="refinement levels (default 0,1,2; three give an observed order)")
    p.add_argument("--refine", choices=tuple(LEVEL_NAMES), default="all",
                   help="all: level k is mesh.refinement = k (every size halves); rim: only mesh.size_rim_mm "
                        "is halved k times, at the scene's refinement (what local refinement at the cone rims buys); "
                        "fillet: only mesh.fillet_elements is doubled k times, at the scene's refinement (the "
                        "elements along each rounded rim's arc; needs geometry.cone_fillet_mm > 0)")
    p.add_argument("--cap", action="append", default=[], metavar="DEGREE=LEVEL",
                   help="finest level solved for a degree, e.g. --cap 2=1 "
                        "(degree-2 rungs above refinement 1 are too slow)")
    p.add_argument("--formulations", default=None,
                   help=f"values of {FORMULATION_KEY} to compare, e.g. displacement,mixed (default: the scene's)")
    p.add_argument("--forces", default=None, help="forces (N) to tabulate (default: every reported force and the peak)")
    p.add_argument("--title", default=None, help="title of the ledger (default: the scene name)")
    p.add_argument("--inprocess", action="store_true", help="solve the rungs in this process (automatic under mpirun)")
    p.add_argument("--redo", action="store_true", help="solve every rung again even if its folder holds a result")
    p.add_argument("--report-only", action="store_true",
                   help="solve nothing: rebuild the ledger from the rungs already in the output folder")
    p.set_defaults(handler=convergence_main)


def rung_main(args: argparse.Namespace, comm: Any) -> int:
    """``suture-fem ledger-rung``: solve one rung into ``--out``."""
    solve_rung(load_scene(args.scene, args.overrides), Path(args.out), comm)
    return 0


def convergence_main(args: argparse.Namespace, comm: Any) -> int:
    """``suture-fem convergence``: check the ladder, solve it, write and summarise the ledger."""
    base = load_scene(args.scene, args.overrides)  # bad input stops here, before any solve
    degrees, refinements = _int_list(args.degrees, "--degrees"), _int_list(args.refinements, "--refinements")
    formulations = [f.strip() for f in args.formulations.split(",")] if args.formulations else None
    forces = _float_list(args.forces) if args.forces else None
    ladder = plan_ladder(base, args.scene, args.overrides, degrees, refinements, formulations, forces,
                         args.refine, _caps(args.cap))
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = usable_folder(args.out or f"results/{name}-convergence")
    rungs, analysis = run_ledger(ladder, out, args.title or name, comm, args.inprocess, args.redo, args.report_only)
    if comm.rank == 0:
        print(f"suture-fem: ledger in {out / 'ledger.md'} ({out / 'ledger.json'}, {out / 'ledger.png'})")
        for fk, per_q in analysis.items():
            for p in per_q.values():
                print(f"  {fk} N  {p['label']}: {p['verdict']}")
    return 0 if all(r.status == "converged" for r in rungs) else 3
