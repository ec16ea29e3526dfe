"""``suture-fem maxload SCENE [--up-to N] [--tol N] [--out DIR]``: bracket the largest force a scene carries.

Argument parsing and printing only; the search is :mod:`suture_fem.studies.maxload`. Exit code 0
when a bracket or a lower bound was found, 3 when the ramp stopped for a numerical reason.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.studies.maxload import max_load
from suture_fem.support.io import usable_folder


def register(subparsers: Any, scene_args: Any) -> None:
    """Add the ``maxload`` subcommand (``scene_args`` adds SCENE and ``--set``)."""
    p = subparsers.add_parser("maxload", help="bracket the largest force a scene carries before a physical limit")
    scene_args(p)
    p.add_argument("--up-to", type=float, default=None, metavar="N",
                   help="highest force to try, N (default: 10 x loading.force_n)")
    p.add_argument("--tol", type=float, default=0.01, metavar="N", help="bracket width, N (default 0.01)")
    p.add_argument("--out", default=None, help="output folder (default: results/<scene>-maxload)")
    p.set_defaults(handler=maxload_command)


def maxload_command(args: argparse.Namespace, comm: Any) -> int:
    """Run the search and print the bracket, the lower bound, or the numerical stop."""
    scene = load_scene(args.scene, list(args.overrides))
    up_to = args.up_to if args.up_to is not None else 10.0 * scene.loading.force_n
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = usable_folder(args.out or f"results/{name}-maxload")
    rec = max_load(scene, comm, up_to, args.tol, out)
    if comm.rank == 0:
        if rec["bracketed"]:
            print(f"suture-fem: the scene carries {rec['bracket_n'][0]:.6g} N and fails at {rec['bracket_n'][1]:.6g} N "
                  f"(tolerance {rec['tolerance_n']:g} N): {rec['cause']}; {out / 'maxload.json'}")
        elif rec.get("limit") == "physical":
            lo, hi = rec["bracket_n"]
            print(f"suture-fem: the scene carries {lo:.6g} N and fails at {hi:.6g} N: {rec['cause']}, a bracket "
                  f"{rec['width_n']:.3g} N wide, NOT within --tol {rec['tolerance_n']:g} N; {out / 'maxload.json'}")
        elif rec["cause"] is None:
            print(f"suture-fem: carries at least {up_to:g} N (no limit below --up-to); {out / 'maxload.json'}")
        else:
            print(f"suture-fem: the ramp stopped at {rec['max_force_n']:.6g} N for a numerical reason "
                  f"({rec['cause']}), not a physical limit; {out / 'maxload.json'}")
    return 3 if rec.get("limit") == "numerical" else 0
