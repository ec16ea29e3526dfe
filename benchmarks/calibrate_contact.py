"""Benchmark: reproduce's calibration under a Coulomb interface, its fit against a derivative-free root.

``calibrate``'s sensitivities with Coulomb friction hold the slip bound frozen (docs/contact.md,
"Sensitivities with contact"), so they are not the exact derivative of the settled state. This checks
what matters for the fit: on reproduce's own case (``paper_reproduction``, four cones on their mesh rung,
USUM 4.0 mm at 1 N) the calibration's fitted ``materials.tissue_scale`` against ``scipy.optimize.brentq``
on the same ramps from rest (no derivative), then the direct dUSUM/dtissue_scale at the root against a
central difference of two ramps (+-1e-4). The refusal of ``calibrate`` is bypassed here for the check.

    .venv/bin/python benchmarks/calibrate_contact.py --where thread --mu 0.1 --bracket 0.32 0.40 [--out x.json]
"""

from __future__ import annotations

import argparse
import json
import time

from mpi4py import MPI
from scipy import optimize

import suture_fem.studies.calibrate.study as study
from suture_fem.pipeline import load_scene
from suture_fem.studies.calibrate.data import USUM
from suture_fem.studies.calibrate.keys import parse_fit
from suture_fem.studies.calibrate.model import Case, Cost
from suture_fem.studies.reproduce.calibration import target_point
from suture_fem.studies.reproduce.solve import case_scene

KEY = "materials.tissue_scale"


def main(argv: list[str] | None = None) -> int:
    """The fit, the root, the derivative at the root; printed and written as JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--where", choices=("thread", "cone"), default="thread")
    ap.add_argument("--mu", type=float, default=0.1)
    ap.add_argument("--bracket", type=float, nargs=2, default=(0.32, 0.40))
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    scene = load_scene("paper_reproduction", [f'effects.{args.where}_interface="coulomb"',
                                              f"effects.friction_coefficient={args.mu}"])
    scene = case_scene(scene, target_point().cones, frozenset())
    study.check_scene = lambda s: None  # the refusal under test
    out: dict = {"where": args.where, "mu": args.mu}
    c0 = time.process_time()
    rec = study.calibrate(scene, [target_point()], [parse_fit(KEY, scene)], MPI.COMM_WORLD, curve=False)
    p = rec["parameters"][KEY]
    out["fit"] = {"value": p["value"], "ci95": p["ci95"], "status": rec["status"], "usum": rec["predictions_mm"][0],
                  "dusum": rec["sensitivities_mm"][0][0], "ramps": rec["cost"]["ramps"],
                  "cpu_s": time.process_time() - c0}
    print("fit", json.dumps(out["fit"]), flush=True)
    case, calls = Case(scene, MPI.COMM_WORLD, Cost()), []

    def usum(s: float, keys: list[str]) -> tuple[float, float]:
        case.states = None  # from rest: no warm start
        y, dy = case.solve({KEY: s}, [target_point().force_n], USUM, keys)
        return float(y[0]), float(dy[0, 0]) if keys else 0.0

    def f(s: float) -> float:
        y = usum(s, [])[0]
        calls.append((s, y))
        return y - target_point().value_mm

    c0 = time.process_time()
    root = optimize.brentq(f, *args.bracket, xtol=1e-6)
    out["brentq"] = {"value": root, "calls": calls, "cpu_s": time.process_time() - c0}
    print("brentq", json.dumps(out["brentq"]), flush=True)
    direct = usum(root, [KEY])[1]
    h = 1e-4 * root
    fd = (usum(root + h, [])[0] - usum(root - h, [])[0]) / (2 * h)
    out["derivative"] = {"direct": direct, "central_difference": fd, "rel": (direct - fd) / fd}
    print("derivative", json.dumps(out["derivative"]), flush=True)
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(out, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
