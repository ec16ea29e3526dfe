"""The critical-distance search in 3-D: the largest ball average of a cell-wise field over positions (collective).

The 3-D counterpart of the disc search of :mod:`suture_fem.outputs.disc`: the average over the ball's part
in the region, on the half model's mirror image, from each cell's overlap volume with the ball
(:mod:`suture_fem.outputs.ball_cells`; the point rule of :mod:`suture_fem.outputs.ball`, biased high at a
sharp rim meshed finer than the ball, is kept as :meth:`BallRegion.rule_averages` for comparison). The
field is constant per cell: P1 tetrahedra's stress and strain are; with P2 a cell's value is the mean of
its quadrature-point values (a piecewise-constant view). The 2-D search's steps, adapted:

* candidate centres of two kinds, up to :data:`CANDIDATES` of each, at least R apart: the region's largest
  cell values at the cells' centroids (:func:`top_cells`), and the local maxima of a coarse view of the ball
  average on a grid fixed in space (:meth:`BallRegion.coarse_starts`). The search near the cones takes the
  largest values of the cells whose centroid is near a cone as its first kind;
* of each kind, the :data:`STARTS` candidates with the largest ball averages of their own are climbed: a
  3 x 3 x 3 grid of centres fixed in space, of spacing R/4, then R/8, R/16 and R/32 (:data:`LEVELS`), moved
  to its best centre while that is better (a pattern search; the 2-D search's 9 x 9 windows would be
  729 balls a window in 3-D);
* a ball's centre must lie in the region (with the mirror, its image in z <= 0 does).

Grids fixed in space, and candidates gathered from every rank and ordered by value and position, make the
search the same on every partition: 2 ranks give the serial answer. Every rank sums the overlaps of its
owned cells; the sums are reduced over ranks, so every rank computes the same averages. Each centre's cells
and overlap volumes are kept (:class:`~suture_fem.outputs.ball_cells.CellOverlap`): later fields and states
only read their values there.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from suture_fem.outputs.ball import ball_rule, point_values, weighted_averages
from suture_fem.outputs.ball_cells import CellOverlap, reduced_averages
from suture_fem.outputs.candidates import _largest
from suture_fem.outputs.climb import climb
from suture_fem.outputs.disc import DiscMax
from suture_fem.support import compat

#: Candidates of each kind (R apart) and how many of each kind, ranked by their own ball average, are climbed.
CANDIDATES, STARTS = 48, 3
#: The climb's grid spacings (fractions of R); every one a multiple of the last.
LEVELS = (1 / 4, 1 / 8, 1 / 16, 1 / 32)
#: Largest number of moves of a level's grid toward a better centre.
MAX_MOVES = 20
#: The coarse view's grid spacing (fraction of R), doubled until the region's box holds at most COARSE_NODES.
COARSE_SPACING, COARSE_NODES = 1 / 2, 100_000
#: Centres whose located points are kept per region (under 2 kB each: 289 points, a 2- and a 4-byte index).
KEPT = 20_000

_STENCIL = [s for s in itertools.product(range(-2, 3), repeat=3) if sum(i * i for i in s) <= 4]  # within 2 nodes
_AROUND = [s for s in itertools.product((-1, 0, 1), repeat=3) if any(s)]

#: A function of ball centres (k, 3) returning which of them the search may use (a boolean mask (k,)).
Allowed = Callable[[np.ndarray], np.ndarray]


class BallRegion:
    """A region's owned cells for the ball averages, and the cells each ball asked for overlaps.

    ``cells``: local owned cell indices; a field is given as one value per cell, in this order.
    ``mirror_z``: the half model z <= 0, read at mirror images above the plane z = 0.
    """

    def __init__(self, mesh: Any, cells: np.ndarray, radius: float, mirror_z: bool):
        self.comm, self.radius, self.mirror = mesh.comm, radius, mirror_z
        self.cells = np.asarray(cells, dtype=np.int32)
        imap = mesh.topology.index_map(mesh.topology.dim)
        self.row = np.full(imap.size_local + imap.num_ghosts, -1, dtype=np.int64)
        self.row[self.cells] = np.arange(len(self.cells))
        vertices = mesh.geometry.x[compat.geometry_dofs(mesh)[self.cells, :4]]
        self.centroids = vertices.mean(axis=1) if len(self.cells) else np.zeros((0, 3))
        self.locate = compat.cell_locator(mesh, self.cells)
        self.offsets, self.weights = ball_rule(radius)
        self.cells_overlap = CellOverlap(vertices, radius, mirror_z)
        self.unit = radius * LEVELS[-1]
        self.kept: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        self.box = _box(self.comm, self.centroids)
        self._coarse: tuple[Any, ...] | None = None

    def fold(self, centres: np.ndarray) -> np.ndarray:
        """Centres (k, 3), those above the symmetry plane moved to their mirror images (with the mirror)."""
        centres = np.array(centres, dtype=float).reshape(-1, 3)
        if self.mirror:
            centres[:, 2] = -np.abs(centres[:, 2])
        return centres

    def averages(self, values: np.ndarray, centres: np.ndarray) -> np.ndarray:
        """The field's average over each ball's part in the region; -inf where the centre is outside it (collective).

        From each cell's overlap volume with the ball (:mod:`suture_fem.outputs.ball_cells`).
        """
        centres = self.fold(centres)
        idx, _ = self.locate(centres, keep=False)
        both = np.zeros((len(centres), 3))
        both[:, :2] = self.cells_overlap.sums(values, centres)
        both[idx, 2] = 1.0
        return reduced_averages(self.comm, both)

    def rule_averages(self, values: np.ndarray, centres: np.ndarray) -> np.ndarray:
        """As :meth:`averages`, from the ball's point rule (:func:`~suture_fem.outputs.ball.ball_rule`)."""
        centres = self.fold(centres)
        k, m = len(centres), len(self.offsets) + 1
        idx, rows = self._located(centres)
        vals, inside = point_values(self.comm, idx, np.asarray(values, dtype=float)[rows], k * m)
        vals, inside = vals.reshape(k, m), inside.reshape(k, m)
        avg, _ = weighted_averages(vals[:, 1:], inside[:, 1:], self.weights)
        return np.where(inside[:, 0] & np.isfinite(avg), avg, -np.inf)

    def _located(self, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point index, cell row) pairs of the points [centre, centre + offsets] of each centre, in order."""
        m = len(self.offsets) + 1
        keys = [c.tobytes() for c in centres]
        missing = [i for i, key in enumerate(keys) if key not in self.kept]
        found: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}
        if missing:
            points = self.fold(centres[missing][:, None, :] + np.vstack([np.zeros(3), self.offsets])[None])
            idx, cells = self.locate(points, keep=False)  # sorted by point
            bounds = np.searchsorted(idx, m * np.arange(len(missing) + 1))
            for j, i in enumerate(missing):
                a, b = bounds[j], bounds[j + 1]
                found[keys[i]] = ((idx[a:b] - j * m).astype(np.int16), self.row[cells[a:b]].astype(np.int32))
            if len(self.kept) < KEPT:
                self.kept.update(found)
        parts = [found[key] if key in found else self.kept[key] for key in keys]
        if not parts:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        idx = np.concatenate([p[0].astype(np.int64) + i * m for i, p in enumerate(parts)])
        return idx, np.concatenate([p[1] for p in parts])

    def coarse_starts(self, values: np.ndarray, count: int = CANDIDATES) -> np.ndarray:
        """Candidate centres (k, 3) from a coarse view of the ball average, the same on every rank (collective).

        The field is sampled at the nodes of a grid fixed in space over the region's box (spacing R/2,
        doubled until it has at most :data:`COARSE_NODES` nodes; a node in several cells takes their largest
        value), and the mean of the samples within two spacings of each node (33 of them) stands for the
        ball average there, with no regard to the mesh. The ``count`` largest local maxima of it, R apart.
        """
        if self._coarse is None:
            self._coarse = self._coarse_grid()
        nodes, idx, rows, reflect = self._coarse
        if nodes is None:
            return np.zeros((0, 3))
        shape = nodes.shape[:3]
        vals = np.full(int(np.prod(shape)), -np.inf)  # a node on a face (the planes y = 0, z = 0) takes the largest
        np.maximum.at(vals, idx, np.asarray(values, dtype=float)[rows])  # value: the same on any partition
        if self.comm.size > 1:
            from mpi4py import MPI

            self.comm.Allreduce(MPI.IN_PLACE, vals, op=MPI.MAX)
        inside = np.isfinite(vals).reshape(shape).astype(float)
        vals = np.where(inside > 0, vals.reshape(shape), 0.0)
        den = _window_sum(inside, reflect)
        avg = np.where((inside > 0) & (den > 0), _window_sum(vals * inside, reflect) / np.maximum(den, 1e-300), -np.inf)
        peak = np.all([avg >= s for s in _shifts(avg, _AROUND, -np.inf, reflect)], axis=0) & np.isfinite(avg)
        at = np.flatnonzero(peak)
        return spread(nodes.reshape(-1, 3)[at[np.argsort(-avg.reshape(-1)[at], kind="stable")]], self.radius, count)

    def _coarse_grid(self) -> tuple[Any, ...]:
        """(nodes (n0, n1, n2, 3), their located (index, row) pairs, whether the last z plane is the mirror's)."""
        lo, hi = self.box
        if not np.all(np.isfinite([*lo, *hi])):  # no cell of the region on any rank
            return None, None, None, False
        h = COARSE_SPACING * self.radius
        while np.prod(np.maximum(hi - lo, 0.0)) / h**3 > COARSE_NODES:
            h *= 2.0
        axes = [np.arange(np.floor(lo[d] / h) - 1, np.ceil(hi[d] / h) + 2) * h for d in range(3)]
        if self.mirror:
            axes[2] = axes[2][axes[2] <= 0.0]
        reflect = self.mirror and len(axes[2]) >= 3 and axes[2][-1] == 0.0
        nodes = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
        idx, cells = self.locate(nodes.reshape(-1, 3), keep=False)
        return nodes, idx, self.row[cells], reflect


def _box(comm: Any, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (lo, hi) of points (k, 3) on every rank (collective); inf / -inf with none."""
    from mpi4py import MPI

    lo, hi = np.empty(3), np.empty(3)
    comm.Allreduce(points.min(axis=0) if len(points) else np.full(3, np.inf), lo, op=MPI.MIN)
    comm.Allreduce(points.max(axis=0) if len(points) else np.full(3, -np.inf), hi, op=MPI.MAX)
    return lo, hi


def _shifts(a: np.ndarray, offsets: list[tuple[int, ...]], fill: float, reflect: bool) -> list[np.ndarray]:
    """``a`` at index (i + di, j + dj, k + dk) for each offset, ``fill`` beyond its edges.

    With ``reflect`` the last plane of the third index is a mirror plane: the nodes beyond it are those below it.
    """
    padded = np.pad(a, 2, constant_values=fill)
    if reflect:
        padded[..., -2], padded[..., -1] = padded[..., -4], padded[..., -5]
    n = a.shape
    return [padded[2 + i: 2 + i + n[0], 2 + j: 2 + j + n[1], 2 + k: 2 + k + n[2]] for i, j, k in offsets]


def _window_sum(a: np.ndarray, reflect: bool) -> np.ndarray:
    """The sum of ``a`` over the coarse view's stencil around every node (0 beyond the edges)."""
    total = np.zeros_like(a)
    for view in _shifts(a, _STENCIL, 0.0, reflect):
        total += view
    return total


def spread(candidates: np.ndarray, separation: float, count: int) -> np.ndarray:
    """The first ``count`` of candidates (k, 3), in order, each at least ``separation`` from those taken before."""
    c = np.asarray(candidates, dtype=float).reshape(-1, 3)
    open_, taken = np.arange(len(c)), []
    while len(taken) < count and len(open_):
        i, rest = int(open_[0]), open_[1:]
        taken.append(i)
        open_ = rest[np.linalg.norm(c[rest] - c[i], axis=1) >= separation]
    return c[taken]


def top_cells(comm: Any, values: np.ndarray, centroids: np.ndarray, separation: float,
              count: int = CANDIDATES) -> np.ndarray:
    """The centroids of the ``count`` largest cell values over all ranks, at least ``separation`` apart (k, 3)."""
    order = _largest(values, 50 * count)
    local = np.column_stack([values[order], centroids[order]]) if len(order) else np.zeros((0, 4))
    merged = np.concatenate(comm.allgather(local))
    merged = merged[np.lexsort((-merged[:, 3], -merged[:, 2], -merged[:, 1], -merged[:, 0]))]  # ties by position
    return spread(merged[: 50 * count, 1:], separation, count)  # the largest over all ranks: as on one rank


def max_ball_average(ball: BallRegion, values: np.ndarray, starts: tuple[np.ndarray, ...],
                     allowed: Allowed | None = None, known: dict | None = None) -> DiscMax:
    """The largest ball average over centres in the region (and ``allowed``), climbed from ``starts`` (collective).

    ``starts``: groups of candidate centres (k, 3), the same on every rank; the :data:`STARTS` of each group
    with the largest averages are climbed, a start within R of one taken before skipped. ``known``: the
    averages at grid centres already computed for this field (shared between searches).
    """
    known = {} if known is None else known
    chosen = []
    for group in starts:
        group = ball.fold(group)
        if allowed is not None:
            group = group[allowed(group)]
        if len(group):
            chosen.append(group[np.argsort(-ball.averages(values, group), kind="stable")[:STARTS]])
    climbs: list[np.ndarray] = []
    for s in np.concatenate(chosen) if chosen else ():
        if all(np.linalg.norm(s - c) >= ball.radius for c in climbs):
            climbs.append(s)
    return DiscMax(*climb(climbs, LEVELS, MAX_MOVES, ball.unit, lambda c: ball.averages(values, c), allowed, known,
                          fold=_mirrored if ball.mirror else None))


def _mirrored(grid: np.ndarray) -> np.ndarray:
    """Grid points (in units) folded onto the half model's side of its symmetry plane z = 0."""
    grid[:, 2] = -np.abs(grid[:, 2])
    return grid


def ball_maxima(ball: BallRegion, values: np.ndarray, near: tuple[Allowed, np.ndarray] | None = None
                ) -> tuple[DiscMax, DiscMax | None]:
    """The largest ball average and, with ``near``, the largest with the centre near a cone (collective).

    ``near``: (which centres are near a cone, which of the region's cells have their centroid there). As in
    2-D, a near-cone maximum above the overall one found (from other starts) is the overall maximum.
    """
    coarse, known = ball.coarse_starts(values), {}  # the two searches share the averages both compute
    found = max_ball_average(ball, values, (top_cells(ball.comm, values, ball.centroids, ball.radius), coarse),
                             known=known)
    if near is None:
        return found, None
    allowed, cells = near
    near_max = found
    if found.at is None or not allowed(np.array([found.at]))[0]:
        tops = top_cells(ball.comm, values[cells], ball.centroids[cells], ball.radius)
        near_max = max_ball_average(ball, values, (tops, coarse), allowed, known)
    return (near_max if near_max.value > found.value else found), near_max
