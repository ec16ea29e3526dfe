"""Benchmark: the 3-D critical-distance ball's largest averages, exact for a cell-wise field, against the rule's.

The ball average of a field constant on each tetrahedron is sum_c v_c |B n c| / sum_c |B n c|: exact with
the ball's overlap volume with each cell, which PyPI's ``overlap`` computes (Strobl et al., "Exact
calculation of the overlap volume of spheres and mesh elements"). It is not a dependency of the package:
install it beside Debian's numpy, without its own (``.venv/bin/pip install --no-deps overlap``; 0.2.0 ran
here with numpy 1.24.2). Solves one 3-D scene (as ``benchmarks/ball_rule.py``), then searches the whole
tissue with the 288-point rule, the package's sampled cell overlaps (``outputs/ball_cells.py``) and, with
``--exact``, the exact overlap volumes in their place (the same candidates, climbs and mirror), single rank.

    .venv/bin/python benchmarks/ball_exact.py --set geometry.cones=1 --set mesh.size_suture_mm=0.3 \\
        --set mesh.size_rim_mm=0.1 --set mesh.size_far_mm=2.4 [--exact]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.model import Model  # noqa: E402
from suture_fem.outputs import ball_search  # noqa: E402
from suture_fem.outputs.base import State  # noqa: E402
from suture_fem.outputs.critical_distance import CriticalDistance  # noqa: E402
from suture_fem.scene import Scene  # noqa: E402
from suture_fem.scene.load import parse_override  # noqa: E402
from suture_fem.support import compat  # noqa: E402

BASE = ["geometry.dimension=3", "mesh.degree=1", 'output.quantities=["usum","seqv","eptoeqv"]',
        "output.critical_distance_mm=0", "output.critical_distance_layers=false", "loading.force_n=1.0",
        "loading.report_forces_n=[]"]


class ExactOverlap:
    """Per ball centre, the region's cells the ball (and its mirror image) overlaps and the overlap volumes."""

    def __init__(self, region: ball_search.BallRegion, mesh) -> None:
        from scipy.spatial import cKDTree

        self.region = region
        x = mesh.geometry.x[compat.geometry_dofs(mesh)[region.cells, :4]]
        det = np.linalg.det(np.stack([x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]], axis=2))
        x[det < 0] = x[det < 0][:, [1, 0, 2, 3]]  # positive orientation: overlap needs it
        self.x = x
        reach = np.linalg.norm(x - region.centroids[:, None], axis=2).max(axis=1)
        bound = region.radius * 2.0 ** np.ceil(np.log2(np.maximum(reach / region.radius, 1.0)))
        self.buckets = [(b, np.flatnonzero(bound == b)) for b in np.unique(bound)]
        self.trees = [cKDTree(region.centroids[cells]) for _, cells in self.buckets]
        self.kept: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def cells(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(rows, overlap volumes) of the ball and, with the mirror, its mirror image, summed per row."""
        import overlap

        key = centre.tobytes()
        if key not in self.kept:
            spheres = [centre] + ([centre * [1, 1, -1]] if self.region.mirror else [])
            rows, vols = [], []
            for c in spheres:
                sphere = overlap.Sphere(tuple(c), self.region.radius)
                for (bound, cells), tree in zip(self.buckets, self.trees):
                    for n in tree.query_ball_point(c, self.region.radius + bound):
                        v = overlap.overlap_volume(sphere, overlap.Tetrahedron(self.x[cells[n]]))
                        if v > 0:
                            rows.append(cells[n])
                            vols.append(v)
            self.kept[key] = (np.asarray(rows, dtype=np.int64), np.asarray(vols))
        return self.kept[key]

    def averages(self, values: np.ndarray, centres: np.ndarray) -> np.ndarray:
        centres = self.region.fold(centres)
        idx, _ = self.region.locate(centres, keep=False)
        inside = np.zeros(len(centres), dtype=bool)
        inside[idx] = True
        out = np.full(len(centres), -np.inf)
        for i in np.flatnonzero(inside):
            rows, vols = self.cells(centres[i])
            if vols.sum() > 0:
                out[i] = float(np.dot(np.asarray(values)[rows], vols) / vols.sum())
        return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--exact", action="store_true", help="with PyPI's overlap too")
    args = parser.parse_args()
    model = Model(Scene.from_values(dict(parse_override(text) for text in [*BASE, *args.sets])))
    model.solve()
    setup = model.outputs.setup
    print(f"{model.results.run['dofs']:,} dofs, {model.results.run['cells']:,} tetrahedra", flush=True)
    labels = ("288-point rule", "cell overlaps (the package's)", "exact overlap")
    schemes, centres = {}, []
    for label in labels if args.exact else labels[:2]:
        t0 = time.process_time()
        cd = CriticalDistance(setup, radius_mm=0.1)
        region = cd.balls["tissue"][2]
        if label == labels[0]:
            region.averages = region.rule_averages  # the search calls it by this name
        if label == labels[2]:
            region.averages = ExactOverlap(region, model.mesh).averages
        schemes[label] = (cd, region.averages)
        found = cd.in_tissue(State(setup))
        centres += [(label, k, np.asarray(v.at_mm) * 1e-3) for k, v in found.items() if k.startswith("seqv")]
        spent = time.process_time() - t0
        cells = "; ".join(f"{k} {v.value:.6g} at ({', '.join(f'{c:.3f}' for c in v.at_mm)})" for k, v in found.items())
        print(f"{label}, {spent:.1f} s CPU: {cells}", flush=True)
    cross(schemes, centres, State(setup))
    return 0


def cross(schemes: dict, centres: list, state: State) -> None:
    """Every scheme's SEQV ball average at every scheme's SEQV maxima: the schemes' errors at the same centre."""
    for label, key, at in centres:
        row = []
        for other, (cd, averages) in schemes.items():
            layers, mine, _, _ = cd.balls["tissue"]
            fn = dict(cd.fields)["seqv_cd_pa"]
            values = np.concatenate([fn(state, r) for r in layers]).reshape(len(mine), -1)[mine].mean(axis=1)
            row.append(f"{other} {averages(values, at[None])[0]:.6g}")
        print(f"at {label}'s {key} ({', '.join(f'{c * 1e3:.3f}' for c in at)}): {'; '.join(row)}", flush=True)


if __name__ == "__main__":
    raise SystemExit(main())
