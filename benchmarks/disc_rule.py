"""Benchmark: how the 2-D critical-distance disc's largest averages depend on how the disc is integrated.

Solves one 2-D scene (the paper, 1 cone, P2, to 1 N; ``--set`` overrides as for ``suture-fem run``), then
searches the whole tissue's largest disc averages (``outputs/disc.py``) on the same solved state:

* with the point rule alone (the search before the cells' overlaps: 6 radial x 24 angular = 144 points on
  the per-cell linear fits, and finer rules);
* as ``suture-fem run`` does: the 144-point rule's search, then a pattern search on the exact average of the
  fitted field from each cell's overlap with the disc (``outputs/disc_cells.py``);
* the same with the 2,304-point rule leading the search;
* a check of the last stage: the overlaps' average on a scan of spacing R/32 over 2R x 2R around the near-cone
  centre found (the largest of the scan should not exceed the value found).

Prints each variant's maxima, their centres and the search's CPU seconds.

    .venv/bin/python benchmarks/disc_rule.py [--set mesh.refinement=1]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from suture_fem.model import Model  # noqa: E402
from suture_fem.outputs import critical_distance, disc  # noqa: E402
from suture_fem.outputs.base import State  # noqa: E402
from suture_fem.outputs.critical_distance import CriticalDistance  # noqa: E402
from suture_fem.scene import Scene  # noqa: E402
from suture_fem.scene.load import parse_override  # noqa: E402

BASE = ["geometry.cones=1", "mesh.degree=2", 'output.quantities=["usum","seqv","eptoeqv"]',
        "output.critical_distance_mm=0", "output.critical_distance_layers=false", "loading.force_n=1.0",
        "loading.report_forces_n=[]"]
#: (name, (radial, angular) points of the rule, whether the overlaps' pattern search ends the search).
VARIANTS = (("rule 6 x 24", (6, 24), False), ("rule 12 x 48", (12, 48), False), ("rule 24 x 96", (24, 96), False),
            ("overlaps (run)", (6, 24), True), ("overlaps, 24 x 96 leading", (24, 96), True))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()
    model = Model(Scene.from_values(dict(parse_override(text) for text in [*BASE, *args.sets])))
    model.solve()
    setup = model.outputs.setup
    print(f"{model.results.run['dofs']:,} dofs, {model.results.run['cells']:,} cells", flush=True)
    search = disc.max_disc_average
    for name, (radial, angular), exact in VARIANTS:
        disc.RADIAL_POINTS, disc.ANGULAR_POINTS = radial, angular  # disc_rule reads them by name
        disc.disc_rule.cache_clear()
        critical_distance.max_disc_average = lambda *a, exact=exact, **k: search(*a, exact=exact, **k)
        t0 = time.process_time()
        cd = CriticalDistance(setup, radius_mm=0.1)
        found = cd.in_tissue(State(setup))
        spent = time.process_time() - t0
        cells = "; ".join(f"{k} {v.value:.6g} at ({', '.join(f'{c:.3f}' for c in v.at_mm)})" for k, v in found.items())
        print(f"{name}: {spent:.1f} s CPU: {cells}", flush=True)
    near = found["seqv_cd_cone_pa"]
    field, _ = cd.field(State(setup), "tissue", critical_distance.FIELDS[0][2])
    k = np.arange(-32, 33) * cd.radius / 32
    grid = np.array(near.at_mm) * 1e-3 + np.stack(np.meshgrid(k, k), -1).reshape(-1, 2)
    scan = disc.overlap_averages(field, grid, cd.radius, cd.near_cones)
    print(f"scan of {len(grid)} centres around {near.at_mm}: largest SEQV {scan.max():.6g} at "
          f"{np.round(grid[np.argmax(scan)] * 1e3, 4).tolist()} (found {near.value:.6g})", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
