"""The ball average of a cell-wise constant field from each cell's overlap volume with the ball, on one rank.

For a field constant on each tetrahedron the ball average is sum_c v_c |B n c| / sum_c |B n c|. A cell whose
four vertices lie in the ball is inside it (the ball is convex): its whole volume, exactly. A cell farther from
the centre than R plus its own reach (the largest distance of a vertex from its centroid) is outside. Only the
cells the sphere may cut are sampled: their overlap is the cell's volume times the fraction of :data:`SAMPLES`
fixed quasi-random points (scipy's unscrambled Sobol sequence, mapped uniformly onto the tetrahedron) inside
the ball. So the error is confined to the cells on the ball's surface, however small the cells inside are;
a point rule's error is not (each of its points weighs a fixed share of the ball, whatever cell it falls in).
With ``mirror`` the ball's part above the plane z = 0 is read at its mirror image (the half model). Hand-written;
the cells near a centre are found by scipy's k-d tree over the centroids, per group of cells of similar reach.
Each rank sums its own cells; :func:`reduced_averages` reduces the sums over ranks (the 2-D disc's too).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpi4py import MPI

#: Points per cut cell (a power of 2: Sobol's balance; 64 left errors of 2-5 % in the searched maxima on solved meshes).
SAMPLES = 512
#: Most (ball, cell) pairs whose overlap volumes are kept for later fields and states (12 bytes each).
KEPT_PAIRS = 2_000_000


def _reference_points(count: int) -> np.ndarray:
    """Barycentric coordinates (count, 4), uniform on the tetrahedron: sorted Sobol coordinates' spacings."""
    from scipy.stats import qmc

    u = qmc.Sobol(3, scramble=False).random_base2(int(np.log2(count)))
    u = np.sort((u + 0.5 / count) % 1.0, axis=1)  # shifted off the cube's faces
    return np.column_stack([u[:, 0], u[:, 1] - u[:, 0], u[:, 2] - u[:, 1], 1.0 - u[:, 2]])


def reach_groups(centroids: np.ndarray, reach: np.ndarray, radius: float) -> list[tuple[float, np.ndarray, Any]]:
    """Cells grouped by reach (bounds R 2^k, at least R / 64): (bound, the group's cells, a k-d tree of centroids).

    A cell of a group can meet a ball (disc) of radius R only if its centroid is within R + bound of the centre.
    """
    from scipy.spatial import cKDTree

    bound = radius * 2.0 ** np.ceil(np.log2(np.maximum(reach / radius, 1.0 / 64)))
    return [(b, cells, cKDTree(centroids[cells])) for b in np.unique(bound) for cells in [np.flatnonzero(bound == b)]]


def near_cells(groups: list[tuple[float, np.ndarray, Any]], centre: np.ndarray, radius: float) -> list[np.ndarray]:
    """Per group of :func:`reach_groups`, its cells that may meet the ball (disc) of ``radius`` at ``centre``."""
    return [cells[np.asarray(tree.query_ball_point(centre, radius + bound), dtype=np.int64)]
            for bound, cells, tree in groups]


def reduced_averages(comm: Any, both: np.ndarray) -> np.ndarray:
    """The averages from each rank's sums per centre (collective): -inf where no cell holds it or nothing overlaps it.

    ``both`` (m, 3): value x overlap, overlap, and 1 where one of the rank's cells holds the centre; summed over
    the ranks in place.
    """
    if comm.size > 1:
        comm.Allreduce(MPI.IN_PLACE, both, op=MPI.SUM)
    with np.errstate(invalid="ignore", divide="ignore"):
        avg = np.where(both[:, 1] > 0, both[:, 0] / both[:, 1], np.nan)
    return np.where((both[:, 2] > 0) & np.isfinite(avg), avg, -np.inf)


class CellOverlap:
    """Overlap volumes of balls of a radius with a set of tetrahedra ``vertices`` (n, 4, 3), this rank's."""

    def __init__(self, vertices: np.ndarray, radius: float, mirror: bool, samples: int = SAMPLES):
        self.x, self.radius, self.mirror = np.asarray(vertices, dtype=float).reshape(-1, 4, 3), radius, mirror
        self.centroids = self.x.mean(axis=1)
        e = self.x[:, 1:] - self.x[:, :1]
        self.volume = np.abs(np.linalg.det(e)) / 6.0
        self.reach = np.linalg.norm(self.x - self.centroids[:, None], axis=2).max(axis=1)
        self.groups = reach_groups(self.centroids, self.reach, radius)
        bary = _reference_points(samples)
        self.pairs_of_bary = (bary[:, :, None] * bary[:, None, :]).reshape(samples, 16).T.copy()  # (16, samples)
        self.kept: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self.pairs = 0

    def overlaps(self, centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(cells, overlap volumes > 0) of the ball at ``centre`` and, with the mirror, its mirror image."""
        key = np.asarray(centre, dtype=float).tobytes()
        if key in self.kept:
            return self.kept[key]
        spheres = [centre] + ([np.asarray(centre) * [1.0, 1.0, -1.0]] if self.mirror else [])
        cells, vols = [], []
        for c in spheres:
            for near in near_cells(self.groups, c, self.radius):
                if len(near):
                    v = self._volumes(np.asarray(c, dtype=float), near)
                    cells.append(near[v > 0].astype(np.int32))
                    vols.append(v[v > 0])
        out = (np.concatenate(cells), np.concatenate(vols)) if cells else (np.zeros(0, np.int32), np.zeros(0))
        if self.pairs + len(out[0]) <= KEPT_PAIRS:
            self.kept[key], self.pairs = out, self.pairs + len(out[0])
        return out

    def _volumes(self, c: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """The overlap volume of the ball at c with each of ``cells``: whole inside, 0 outside, sampled if cut."""
        r2 = self.radius**2
        inside = (((self.x[cells] - c) ** 2).sum(axis=2) <= r2).all(axis=1)
        apart = np.linalg.norm(self.centroids[cells] - c, axis=1) - self.reach[cells] > self.radius
        v = np.where(inside, self.volume[cells], 0.0)
        cut = np.flatnonzero(~inside & ~apart)
        for part in np.array_split(cut, max(1, -(-len(cut) // 4096))):  # 4,096 cut cells a time: 16 MB
            d = self.x[cells[part]] - c  # |sum_k b_k d_k|^2 = sum_kl b_k b_l (d_k . d_l): one matrix product
            gram = np.matmul(d, d.transpose(0, 2, 1)).reshape(len(part), 16)
            v[part] = (gram @ self.pairs_of_bary <= r2).mean(axis=1) * self.volume[cells[part]]
        return v

    def sums(self, values: np.ndarray, centres: np.ndarray) -> np.ndarray:
        """(m, 2): this rank's sum of value x overlap and of overlap, per centre (reduce over ranks for the average)."""
        out = np.zeros((len(centres), 2))
        values = np.asarray(values, dtype=float)
        for i, c in enumerate(centres):
            cells, vols = self.overlaps(c)
            out[i] = values[cells] @ vols, vols.sum()
        return out
