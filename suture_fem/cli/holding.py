"""``suture-fem holding SCENE [--up-to N] [--tol N] [--calibration FILE] [--out DIR]``: the holding strength.

Argument parsing and printing only; the study is :mod:`suture_fem.studies.holding.study`. Exit code 0
when the first failure was bracketed or the scene carried the pull up to a physical limit or to
``--up-to`` without failing, 3 when a ramp stopped for a numerical reason before any failure.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from suture_fem.model import check
from suture_fem.scene.load import parse_scene
from suture_fem.studies.holding.study import holding, prepared
from suture_fem.support.errors import SceneError
from suture_fem.support.folder_lock import lock_folder, release_folder
from suture_fem.support.parallel import on_root

#: The lock file a holding study holds in its --out for its life (a second one into the folder is refused).
HOLDING_LOCK = ".holding.lock"
#: Causes of a ramp's stop that are a limit of the model's tissue, not of the numerics.
PHYSICAL = ("gent_limit", "inverted_element")


def register(subparsers: Any, scene_args: Any) -> None:
    """Add the ``holding`` subcommand (``scene_args`` adds SCENE and ``--set``)."""
    p = subparsers.add_parser("holding", help="bracket the pull at which the tissue tears or the thread breaks first")
    scene_args(p)
    p.add_argument("--up-to", type=float, default=None, metavar="N",
                   help="highest pull to try, N (default: the thread's breaking force at the high end of its band)")
    p.add_argument("--tol", type=float, default=0.01, metavar="N", help="bracket width, N (default 0.01)")
    p.add_argument("--calibration", default=None, metavar="FILE",
                   help="a calibration.json: its calibrated values are used and their 95 %% intervals widen the band")
    p.add_argument("--out", default=None, help="output folder (default: results/<scene>-holding)")
    p.add_argument("--reports", type=int, default=16, metavar="K",
                   help="reported forces per ramp, 2-64 (default 16; each costs the critical-distance searches)")
    p.add_argument("--no-pictures", action="store_true", help="do not draw failure_index.png")
    p.set_defaults(handler=holding_command)


def read_calibration(path: str, settable: Any) -> dict[str, Any]:
    """The calibration record's parameters, checked before any meshing (SceneError: one line)."""
    from suture_fem.scene.load import read_text_file

    try:
        record = json.loads(read_text_file(Path(path), f"--calibration {path}"))
        params = record["parameters"]
        for key, p in params.items():
            value, (lo, hi) = float(p["value"]), (float(x) for x in p["ci95"])
            if not all(map(math.isfinite, (value, lo, hi))) or not lo <= value <= hi:
                raise ValueError(f"{key}: value {value:g} outside its interval [{lo:g}, {hi:g}]")
            settable(key, value)
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise SceneError(f"--calibration {path}: not a calibration record with parameters, each a value inside "
                         f"its ci95 interval ({exc})") from None
    return record


def holding_command(args: argparse.Namespace, comm: Any) -> int:
    """Run the study and print the answer."""
    for name, value in (("--tol", args.tol), ("--up-to", args.up_to)):
        if value is not None and not (math.isfinite(value) and value > 0):
            raise SceneError(f"holding: {name} = {value:g} N must be a finite number > 0")
    if not 2 <= args.reports <= 64:
        raise SceneError(f"holding: --reports = {args.reports} must be an integer from 2 to 64")
    scene = prepared(parse_scene(args.scene, list(args.overrides)))
    calibration = None
    if args.calibration:
        calibration = read_calibration(args.calibration, lambda k, v: scene.with_values({k: v}))
    check(scene)  # the geometry's checks and the mesh's size, still before any meshing
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = Path(args.out or f"results/{name}-holding")
    lock = on_root(comm, f"locking {out}", lock_folder, out, HOLDING_LOCK, "holding")
    try:
        rec = holding(scene, comm, args.up_to, args.tol, calibration, out, pictures=not args.no_pictures,
                      name=name, grid=args.reports, checked=True)
    finally:
        if lock is not None:
            release_folder(lock, out, HOLDING_LOCK)
    if comm.rank == 0:
        print(f"suture-fem: {summary_line(rec)}; {out / 'holding.json'}")
    stop = rec.get("stop")
    return 3 if rec["force_n"] is None and stop and stop["cause"] not in PHYSICAL else 0


def summary_line(rec: dict[str, Any]) -> str:
    """The answer in one line."""
    if rec["force_n"] is None:
        return rec["note"]
    lo, hi = rec["band_n"]
    band = f"band {lo:.3g} - " + (f"{hi:.3g} N" if hi is not None else f"> {rec['reached_n']:.3g} N")
    where = rec["layer"] if rec["mode"] == "tear" else "thread"
    at = f" at {rec['cone']}" if rec.get("cone") else ""
    return (f"first failure at {rec['force_n']:.4g} N ({rec['mode']}: {where}{at}; bracket "
            f"{rec['bracket_n'][0]:.4g} - {rec['bracket_n'][1]:.4g} N; {band})")
