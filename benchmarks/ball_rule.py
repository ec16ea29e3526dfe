"""Benchmark: how the 3-D critical-distance ball's largest averages depend on its quadrature rule.

Solves one 3-D scene (the paper cylinder, P1, to 1 N; ``--set`` overrides as for ``suture-fem run``), then
searches the whole tissue's largest ball averages (``outputs/ball_search.py``) with the point rule (4 radial
x 6 polar x 12 azimuthal = 288 points, ``outputs/ball.py``; the package's average before the cells' overlap
volumes, ``outputs/ball_cells.py``) and finer ones, on the same solved state; prints
each rule's maxima, their centres and the search's CPU seconds (the first search of a state, and the same
state again, where the located points are kept). ``--overlaps``: the package's cell overlaps
(``outputs/ball_cells.py``) first. ``--default-only``: the default rule alone; ``--layers``:
each tissue layer's searches too (``output.critical_distance_layers``, the default of a scene), the cost
of a report's critical-distance outputs.

    .venv/bin/python benchmarks/ball_rule.py --set geometry.cones=1 --set mesh.size_suture_mm=0.3 \\
        --set mesh.size_rim_mm=0.1 --set mesh.size_far_mm=2.4 [--default-only] [--layers]
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.model import Model  # noqa: E402
from suture_fem.outputs import ball, ball_search  # noqa: E402
from suture_fem.outputs.base import State  # noqa: E402
from suture_fem.outputs.critical_distance import CriticalDistance  # noqa: E402
from suture_fem.scene import Scene  # noqa: E402
from suture_fem.scene.load import parse_override  # noqa: E402

BASE = ["geometry.dimension=3", "mesh.degree=1", 'output.quantities=["usum","seqv","eptoeqv"]',
        "output.critical_distance_mm=0", "output.critical_distance_layers=false", "loading.force_n=1.0",
        "loading.report_forces_n=[]"]
#: (radial, polar, azimuthal) points; the first is the default.
RULES = ((4, 6, 12), (6, 8, 24), (8, 12, 36))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--default-only", action="store_true")
    parser.add_argument("--layers", action="store_true")
    parser.add_argument("--overlaps", action="store_true", help="the package's cell overlaps first")
    args = parser.parse_args()
    overrides = [*BASE, *args.sets, *(["output.critical_distance_layers=true"] if args.layers else [])]
    model = Model(Scene.from_values(dict(parse_override(text) for text in overrides)))
    model.solve()
    setup = model.outputs.setup
    print(f"{model.results.run['dofs']:,} dofs, {model.results.run['cells']:,} tetrahedra", flush=True)
    rules = list(RULES[:1] if args.default_only else RULES)
    for rule in [None, *rules] if args.overlaps else rules:  # the search reads its rule from ball_search's name
        if rule is not None:
            ball_search.ball_rule = functools.partial(ball.ball_rule, radial=rule[0], polar=rule[1], azimuthal=rule[2])
        t0 = time.process_time()
        cd = CriticalDistance(setup, radius_mm=0.1)
        for _, _, region, _ in cd.balls.values():  # the package's average is the cells' overlaps: the rule's here
            if rule is not None:
                region.averages = region.rule_averages
        built = time.process_time() - t0
        spent = []
        for _ in range(2):  # the first search of the state, then the same state again
            t0 = time.process_time()
            state = State(setup)
            for region in ("hypodermis", "dermis", "epidermis"):
                cd.in_region(state, region)
            found = cd.in_tissue(state)
            spent.append(time.process_time() - t0)
        cells = "; ".join(f"{k} {v.value:.6g} at ({', '.join(f'{c:.3f}' for c in v.at_mm)})" for k, v in found.items())
        name = "cell overlaps" if rule is None else f"{rule[0]} x {rule[1]} x {rule[2]} = {np.prod(rule)} points"
        print(f"{name}, CPU s: built {built:.2f}, "
              f"first {spent[0]:.2f}, again {spent[1]:.2f}; tissue: {cells}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
