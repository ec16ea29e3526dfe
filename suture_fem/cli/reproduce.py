"""``suture-fem reproduce [--out DIR]``: the paper's Tables 1 and 2 and Figures 2-4 in one command.

Argument parsing and printing only; the study is :mod:`suture_fem.studies.reproduce`. Exit code 0,
or 3 when a cone count's ramp stopped before 4 N (its converged part is still compared).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.studies.reproduce import SCENE, reproduce
from suture_fem.studies.reproduce.calibration import DEFAULT, parse_key
from suture_fem.studies.reproduce.paper import LABELS
from suture_fem.studies.reproduce.report import calibration_heading, pct
from suture_fem.support.errors import SceneError


def register(subparsers: Any, scene_args: Any) -> None:
    """Add the ``reproduce`` subcommand (its base scene is an option: the built-in one by default)."""
    p = subparsers.add_parser(
        "reproduce", help="the paper's Tables 1 and 2 and Figures 2-4: 1-4 cones at 1-4 N, compared with the paper")
    p.add_argument("--out", default="results/reproduce", help="output folder (default results/reproduce)")
    p.add_argument("--scene", default=SCENE, help=f"base scene (default: the built-in {SCENE!r})")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                   help="override a key of the base scene, e.g. --set mesh.degree=1 for a quick look (repeatable)")
    p.add_argument("--calibrate", default=DEFAULT, metavar="KEY[=LOW:HIGH]|none",
                   help=f"the ONE parameter fitted to USUM 4.0 mm at 4 cones, 1 N before predicting every other "
                        f"value (default {DEFAULT}; e.g. geometry.hypodermis_mm, loading.force_scale; 'none': the "
                        "scene as it is, every value a prediction)")
    p.add_argument("--max-evaluations", type=int, default=20, help="most calibration evaluations (default 20)")
    p.add_argument("--no-pictures", action="store_true", help="skip the field files and the figures")
    p.set_defaults(handler=reproduce_command)


def reproduce_command(args: argparse.Namespace, comm: Any) -> int:
    """Run the study and print where the comparison is, the largest prediction error and any missed trend."""
    scene = load_scene(args.scene, args.overrides)
    parse_key(args.calibrate, scene)  # a bad key or bounds: one line, exit 2, before any meshing
    if args.max_evaluations < 1:
        raise SceneError(f"--max-evaluations {args.max_evaluations}: expected an integer >= 1")
    out = Path(args.out)
    cmp = reproduce(scene, out, comm, calibrate_key=args.calibrate, pictures=not args.no_pictures,
                    scene_name=Path(args.scene).stem if str(args.scene).endswith(".toml") else args.scene,
                    max_evaluations=args.max_evaluations)
    if comm.rank == 0:
        w = cmp["largest_prediction_error"]
        print(f"suture-fem: {out / 'comparison.md'} ({cmp['run']['wall_time_s']:.0f} s)")
        print(f"  {calibration_heading(cmp['calibration']).replace('`', '')}")
        u = cmp["largest_usum_prediction_error"]
        if u:
            print(f"  largest USUM prediction error {pct(u['rel_error'])}: {u['cones']} cones, {u['force_n']:g} N")
        if w:
            print(f"  largest prediction error {pct(w['rel_error'])}: {w['source']} {LABELS[w['quantity']]}, "
                  f"{w['cones']} cones, {w['force_n']:g} N")
        for t in cmp["trends"]:
            if t["holds"] is False:
                print(f"  trend not reproduced: {t['trend']}")
    return 3 if cmp["stopped"] else 0
