"""Benchmark: how the 2-D critical-distance disc's largest averages depend on its quadrature rule.

Solves one 2-D scene (the paper, 1 cone, P2, to 1 N; ``--set`` overrides as for ``suture-fem run``), then
searches the whole tissue's largest disc averages (``outputs/disc.py``) with the default rule (6 radial x 24
angular = 144 points, on the per-cell linear fits) and with finer ones, on the same solved state; prints each
rule's maxima, their centres and the search's CPU seconds.

    .venv/bin/python benchmarks/disc_rule.py [--set mesh.refinement=1]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.model import Model  # noqa: E402
from suture_fem.outputs import disc  # noqa: E402
from suture_fem.outputs.base import State  # noqa: E402
from suture_fem.outputs.critical_distance import CriticalDistance  # noqa: E402
from suture_fem.scene import Scene  # noqa: E402
from suture_fem.scene.load import parse_override  # noqa: E402

BASE = ["geometry.cones=1", "mesh.degree=2", 'output.quantities=["usum","seqv","eptoeqv"]',
        "output.critical_distance_mm=0", "output.critical_distance_layers=false", "loading.force_n=1.0",
        "loading.report_forces_n=[]"]
#: (radial, angular) points; the first is the default.
RULES = ((6, 24), (12, 48), (24, 96))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()
    model = Model(Scene.from_values(dict(parse_override(text) for text in [*BASE, *args.sets])))
    model.solve()
    setup = model.outputs.setup
    print(f"{model.results.run['dofs']:,} dofs, {model.results.run['cells']:,} cells", flush=True)
    for radial, angular in RULES:
        disc.RADIAL_POINTS, disc.ANGULAR_POINTS = radial, angular  # disc_rule reads them by name
        disc.disc_rule.cache_clear()
        t0 = time.process_time()
        found = CriticalDistance(setup, radius_mm=0.1).in_tissue(State(setup))
        spent = time.process_time() - t0
        cells = "; ".join(f"{k} {v.value:.6g} at ({', '.join(f'{c:.3f}' for c in v.at_mm)})" for k, v in found.items())
        print(f"{radial} x {angular} = {radial * angular} points, {spent:.1f} s CPU: {cells}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
