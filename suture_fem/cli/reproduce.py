"""``suture-fem reproduce [--out DIR] [--jobs N]``: the paper's Tables 1 and 2 and Figures 2-4 in one command.

Argument parsing and printing only; the study is :mod:`suture_fem.studies.reproduce`. Exit code 0 when
every paper value has ours (a ramp that stopped past them, e.g. at a Gent limit, is printed as a
finding), 3 when one is missing (a ramp stopped before it; its converged part is still compared).
``suture-fem reproduce-ramp FOLDER/case.json`` is one cone count's ramp in its own process (what
``--jobs`` runs; not meant to be typed).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.scene.load import parse_override
from suture_fem.studies.paper import CONES, LABELS
from suture_fem.studies.reproduce import SCENE, reproduce
from suture_fem.studies.reproduce.calibration import DEFAULT, parse_key
from suture_fem.studies.reproduce.report import calibration_heading, pct
from suture_fem.support.errors import SceneError
from suture_fem.support.io import usable_folder


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
    p.add_argument("--jobs", default=None, metavar="N",
                   help="cone counts solved at once, each in its own process (default: min(cores, cone counts); "
                        "1: one after the other in this process, as under mpirun)")
    p.add_argument("--mesh", choices=("rungs", "scene"), default="rungs",
                   help="rungs (default): each cone count on its mesh rung, the cheapest with USUM within 1 %% of "
                        "the mesh-converged value (docs/speed.md; a --set mesh.KEY still wins); scene: the "
                        "scene's own mesh for every cone count")
    p.add_argument("--cones", type=int, nargs="+", default=None, metavar="N",
                   help="solve only these cone counts (default: all of the paper's, 1 2 3 4); the values of the "
                        "others are then missing (exit 3). The calibration solves its 4 cones regardless")
    p.set_defaults(handler=reproduce_command)
    p = subparsers.add_parser("reproduce-ramp", help="(internal) one cone count's ramp of `reproduce --jobs`")
    p.add_argument("cases", nargs="+", help="the case.json files `reproduce` wrote, solved in turn")
    p.set_defaults(handler=ramp_command)


def ramp_command(args: argparse.Namespace, comm: Any) -> int:
    """Cone counts' ramps from the case files ``reproduce --jobs`` wrote (exit 3: one stopped)."""
    from suture_fem.studies.reproduce.jobs import run_case_files

    return run_case_files([Path(c) for c in args.cases], comm)


def _jobs(text: str | None, comm: Any) -> int:
    """``--jobs``: an integer >= 1 (1 under mpirun); default min(cores, cone counts)."""
    from suture_fem.studies.reproduce.jobs import default_jobs

    if text is None:
        return 1 if comm.size > 1 else default_jobs(len(CONES))
    try:
        jobs = int(text)
    except ValueError:
        jobs = 0
    if jobs < 1:
        raise SceneError(f"--jobs {text}: expected an integer >= 1")
    if jobs > 1 and comm.size > 1:
        raise SceneError(f"--jobs {text}: under mpirun the ramps run one after the other on all ranks; use 1")
    return jobs


def reproduce_command(args: argparse.Namespace, comm: Any) -> int:
    """Run the study and print where the comparison is, the largest prediction error and any missed trend."""
    scene = load_scene(args.scene, args.overrides)
    usable_folder(args.out)
    parse_key(args.calibrate, scene)  # a bad key or bounds: one line, exit 2, before any meshing
    if args.max_evaluations < 1:
        raise SceneError(f"--max-evaluations {args.max_evaluations}: expected an integer >= 1")
    cones = tuple(sorted(set(args.cones))) if args.cones else CONES
    if not set(cones) <= set(CONES):
        raise SceneError(f"--cones {' '.join(map(str, args.cones))}: the paper's cone counts are "
                         f"{', '.join(map(str, CONES))}")
    jobs = _jobs(args.jobs, comm)
    keys = {parse_override(o)[0] for o in args.overrides}
    fixed = frozenset(k for k in keys if k.startswith("mesh.")) if args.mesh == "rungs" else None
    # the rungs' error estimates were measured on the built-in scene: not shown for another geometry or material
    estimates = args.scene == SCENE and not any(k.split(".")[0] in ("geometry", "mesh", "materials", "effects")
                                                for k in keys)
    out = Path(args.out)
    cmp = reproduce(scene, out, comm, calibrate_key=args.calibrate, pictures=not args.no_pictures,
                    scene_name=Path(args.scene).stem if str(args.scene).endswith(".toml") else args.scene,
                    max_evaluations=args.max_evaluations, fixed=fixed, jobs=jobs, cones=cones,
                    estimates=estimates and args.mesh == "rungs")
    if comm.rank == 0:
        w = cmp["largest_prediction_error"]
        run = cmp["run"]
        print(f"suture-fem: {out / 'comparison.md'} ({run['wall_time_s']:.1f} s wall, {run['cpu_time_s']:.1f} s CPU "
              f"with {run['jobs']} job(s); the ramps {run['ramps_cpu_time_s']:.1f} s CPU)")
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
        for f in cmp["findings"]:
            print(f"  finding: {f}")
        for m in cmp["missing"]:
            print(f"  missing: {m}")
    return 3 if cmp["missing"] else 0
