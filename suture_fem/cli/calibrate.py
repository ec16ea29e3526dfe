"""``suture-fem calibrate SCENE --data CURVE.csv|paper --fit KEY[=LOW:HIGH] [...] [--out DIR]``.

Argument parsing and printing only; the study is :mod:`suture_fem.studies.calibrate`. Bad data files,
keys and bounds: one line, exit 2, before any meshing.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.studies.calibrate import calibrate, load, parse_fit
from suture_fem.studies.calibrate.study import check_scene
from suture_fem.support.errors import SceneError
from suture_fem.support.io import usable_folder


def register(subparsers: Any, scene_args: Any) -> None:
    """Add the ``calibrate`` subcommand (``scene_args`` adds SCENE and ``--set``)."""
    p = subparsers.add_parser("calibrate", help="fit scene keys to a measured pull curve, with 95 %% intervals")
    scene_args(p)
    p.add_argument("--data", required=True, metavar="CURVE.csv|paper",
                   help="rows force_n,displacement_mm[,sd_mm] of the thread end, or 'paper' (its USUM values)")
    p.add_argument("--fit", action="append", required=True, metavar="KEY[=LOW:HIGH]",
                   help="a key to fit, with optional bounds (repeatable), e.g. materials.tissue_scale=0.2:5")
    p.add_argument("--max-evaluations", type=int, default=30, help="most model evaluations (default 30)")
    p.add_argument("--out", default=None, help="output folder (default results/<scene>-calibrate)")
    p.set_defaults(handler=calibrate_command)


def calibrate_command(args: argparse.Namespace, comm: Any) -> int:
    """Validate everything, fit, print each parameter with its interval and the identifiability verdict."""
    scene = load_scene(args.scene, list(args.overrides))
    check_scene(scene)
    points = load(args.data)
    keys = [parse_fit(text, scene) for text in args.fit]
    if len({k.key for k in keys}) != len(keys):
        raise SceneError("--fit: a key is given twice")
    if args.max_evaluations < 1:
        raise SceneError(f"--max-evaluations {args.max_evaluations}: expected an integer >= 1")
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = usable_folder(args.out or f"results/{name}-calibrate")
    rec = calibrate(scene, points, keys, comm, out, max_evaluations=args.max_evaluations)
    if comm.rank == 0:
        print(f"suture-fem: {out / 'calibration.md'}")
        for key, p in rec["parameters"].items():
            print(f"  {key} = {p['value']:.6g}  95 % [{p['ci95'][0]:.6g}, {p['ci95'][1]:.6g}]  ({p['sensitivity']})")
        print(f"  {rec['identifiability']['verdict']}")
        for c in rec.get("curve", []):  # the predictions at the largest force, each with its 95 % band
            scale, unit = (1e-3, " kPa") if c["unit"] == "Pa" else (1.0, " mm" if c["unit"] == "mm" else "")
            cones = f"{c['cones']} cones, " if c["cones"] is not None else ""
            print(f"  predicted {c['quantity']} at {cones}{c['force_n'][-1]:g} N: {c['model'][-1] * scale:.4g}{unit} "
                  f"+- {c['band95'][-1] * scale:.2g}{unit} (95 %)")
    return 0
