"""What the disc averages of :mod:`suture_fem.outputs.disc` keep between fields: located and prepared points.

Where a point falls among a region's cells, the cell's row in a fitted field's coefficients and the
point's offset from the cell's centre depend on the mesh, the region's cells and the point only, not on
the field's values. The critical-distance searches ask for the same points again and again: grids fixed
in space, at every reported force, for every quantity, and in every later answer of a
:class:`suture_fem.Model` (on the paper scene about 80 % of a later answer's batches of disc centres are
batches an earlier answer asked for). :class:`DiscPoints` keeps, per region:

* per disc centre, the cells of its centre and of its rule points (:meth:`DiscPoints.located`);
* per batch of points asked for (a batch of disc centres, a coarse view's grid), the points prepared for
  evaluation (:class:`Prepared`: rows, offsets, the groups of the per-point maximum) and the disc
  rule's 2 pi r weights, so that a field's values there are a few numpy operations
  (:meth:`Prepared.values`), the same operations in the same order as without them: the same numbers,
  bit for bit.

No communication: each rank keeps its own cells.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from typing import Any, NamedTuple

import numpy as np


class Prepared(NamedTuple):
    """Points of a field's cells ready for evaluation: everything that does not depend on the field's values.

    ``size`` points; per (point, cell) pair, sorted by point: the point's index ``idx``, the cell's row
    ``rows`` in the coefficients and the point's offset ``d0``, ``d1`` from the cell's centre;
    ``starts`` (None: ``idx`` not sorted) the first pair of each point and ``group`` that point.
    """

    size: int
    idx: np.ndarray
    rows: np.ndarray
    d0: np.ndarray
    d1: np.ndarray
    starts: np.ndarray | None
    group: np.ndarray | None

    @classmethod
    def of(cls, points: np.ndarray, located: tuple[np.ndarray, np.ndarray] | None, row: np.ndarray,
           centre: np.ndarray) -> Prepared:
        """From the (point index, cell) pairs of ``points`` and a field's cell rows and centres."""
        if located is None:
            empty = np.zeros(0, dtype=np.int64)
            return cls(len(points), empty, empty, np.zeros(0), np.zeros(0), None, None)
        idx, cells = located
        rows = row[cells]
        d = points[idx] - centre[rows]
        starts, group = _groups(idx)
        return cls(len(points), idx, rows, d[:, 0].copy(), d[:, 1].copy(), starts, group)

    def values(self, columns: np.ndarray) -> np.ndarray:
        """The field of per-cell coefficients at the points: the largest over a point's cells; -inf: none.

        ``columns`` (3, n): the coefficients a, b and c of the n cells (each row contiguous).
        """
        local = np.full(self.size, -np.inf)
        if not len(self.idx):
            return local
        rows = self.rows
        vals = columns[1][rows]  # a + b d0 + c d1 in place: (b d0 + a) + c d1, the same sums (addition commutes)
        vals *= self.d0
        vals += columns[0][rows]
        term = columns[2][rows]
        term *= self.d1
        vals += term
        if self.starts is None:
            _max_into(local, self.idx, vals)
        else:  # each point's largest over its cells (max(-inf, v) is v: the fresh array needs no comparison)
            local[self.group] = np.maximum.reduceat(vals, self.starts)
        return local

    @property
    def nbytes(self) -> int:
        """Memory held (bytes)."""
        return sum(a.nbytes for a in (self.idx, self.rows, self.d0, self.d1, self.starts, self.group) if a is not None)


class DiscPoints:
    """Where the points of the disc rule around each centre fall among a region's cells, and prepared batches.

    It also keeps what every field fitted on the region's cells shares: the cells' centres and rows and
    the least-squares system of the fit (``cells``, set by :class:`~suture_fem.outputs.disc.CellField`).
    Each centre keeps its centre's cells and its rule points' indices and cells (under 1 kB); at most
    ``limit`` centres are kept (beyond it, new ones are located every time). Prepared batches are kept
    up to ``batch_bytes`` (the least recently used one goes first; docs/api.md gives how many of a later
    answer's batches an earlier answer had asked for, as measured).
    """

    def __init__(self, locate: Any, limit: int = 50_000, batch_bytes: int = 32 * 2**20):
        self.locate, self.limit, self.batch_bytes = locate, limit, batch_bytes
        self.kept: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        #: the fields' cell centres, rows and least-squares system (they too depend on the points alone)
        self.cells: tuple[np.ndarray, np.ndarray, Any] | None = None
        self.batches: OrderedDict[bytes, tuple[Prepared, np.ndarray | None]] = OrderedDict()
        #: per coarse view (its key): its grid, where the field was, the 2 pi r weights and their window sums
        self.coarse: dict[bytes, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        #: per radius, the cells' overlaps with discs (:class:`~suture_fem.outputs.disc_cells.DiscOverlap`)
        self.overlaps: dict[float, Any] = {}
        self._bytes = 0

    def prepared_discs(self, centres: np.ndarray, offsets: np.ndarray, weights: np.ndarray, row: np.ndarray,
                       centre: np.ndarray) -> tuple[Prepared, np.ndarray]:
        """The points ``[centres, centre 0 + offsets, ...]`` prepared, and the rule's 2 pi r weights (k, m)."""
        key = _digest(b"discs", offsets, centres)
        if key in self.batches:
            self.batches.move_to_end(key)
            return self.batches[key]
        points = np.concatenate([centres, (centres[:, None, :] + offsets[None, :, :]).reshape(-1, 2)])
        w = weights[None, :] * np.abs(points[len(centres):, 0]).reshape(len(centres), -1)
        return self._keep(key, Prepared.of(points, self.located(centres, offsets), row, centre), w)

    def prepared_points(self, points: np.ndarray, row: np.ndarray, centre: np.ndarray,
                        key: bytes | None = None) -> Prepared:
        """Any points (m, 2) prepared (a coarse view's grid: the same grid at every state).

        ``key``: bytes that name these points alone (a coarse view's box and radius), so the points need
        no digest; None: a digest of the points.
        """
        key = _digest(b"points", points) if key is None else key
        if key in self.batches:
            self.batches.move_to_end(key)
            return self.batches[key][0]
        located = self.locate(np.column_stack([points, np.zeros(len(points))]), keep=False) if len(points) else None
        return self._keep(key, Prepared.of(points, located, row, centre), None)[0]

    def _keep(self, key: bytes, prepared: Prepared, w: np.ndarray | None) -> tuple[Prepared, Any]:
        size = prepared.nbytes + (w.nbytes if w is not None else 0)
        while self.batches and self._bytes + size > self.batch_bytes:
            _, (old, old_w) = self.batches.popitem(last=False)
            self._bytes -= old.nbytes + (old_w.nbytes if old_w is not None else 0)
        if size <= self.batch_bytes:
            self.batches[key] = (prepared, w)
            self._bytes += size
        return prepared, w

    def located(self, centres: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point index, cell) pairs of ``[centres, centre 0 + offsets, ...]``, sorted by point index."""
        m = len(offsets)
        tag = offsets.tobytes()[:16] + np.float64(np.abs(offsets).max()).tobytes()
        keys = [tag + c.tobytes() for c in np.ascontiguousarray(centres, dtype=np.float64)]
        missing = [i for i, key in enumerate(keys) if key not in self.kept]
        found = dict(zip((keys[i] for i in missing), self._locate(centres[missing], offsets))) if missing else {}
        if len(self.kept) < self.limit:
            self.kept.update(found)
        own, rule, hits = zip(*(found.get(key) or self.kept[key] for key in keys))
        k = len(centres)
        n_own, n_rule = np.fromiter(map(len, own), np.int64, k), np.fromiter(map(len, rule), np.int64, k)
        idx = np.concatenate([np.repeat(np.arange(k), n_own),
                              np.repeat(k + m * np.arange(k), n_rule) + np.concatenate(rule)])
        return idx, np.concatenate(own + hits)

    def _locate(self, centres: np.ndarray, offsets: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per centre: (its centre's cells, its rule points' indices, their cells)."""
        k, m = len(centres), len(offsets)
        points = np.concatenate([centres, (centres[:, None, :] + offsets[None, :, :]).reshape(-1, 2)])
        idx, cells = self.locate(np.column_stack([points, np.zeros(len(points))]), keep=False)
        own = np.searchsorted(idx, np.arange(k + 1))
        rule = np.searchsorted(idx, k + m * np.arange(k + 1))
        return [(cells[own[i]:own[i + 1]].copy(), (idx[rule[i]:rule[i + 1]] - (k + i * m)).astype(np.int16),
                 cells[rule[i]:rule[i + 1]].copy()) for i in range(k)]


def _groups(idx: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(first pair of each point, that point) of sorted point indices; (None, None) when they are not sorted."""
    if not len(idx) or np.any(idx[1:] < idx[:-1]):
        return None, None
    starts = np.flatnonzero(np.r_[True, idx[1:] != idx[:-1]])
    return starts, idx[starts]


def _max_into(out: np.ndarray, idx: np.ndarray, vals: np.ndarray, starts: np.ndarray | None = None,
              group: np.ndarray | None = None) -> None:
    """out[i] = max(out[i], every vals[k] with idx[k] = i), as ``np.maximum.at`` (which numpy < 1.25 runs slowly).

    The locators give ``idx`` sorted (points in order, a point on a shared edge once per cell): the
    groups of equal indices (``starts``, ``group``: :func:`_groups`, found here when not given) are
    then reduced at once; any other order falls back to ``np.maximum.at``.
    """
    if len(idx) == 0:
        return
    if starts is None:
        starts, group = _groups(idx)
    if starts is None:
        np.maximum.at(out, idx, vals)
        return
    out[group] = np.maximum(out[group], np.maximum.reduceat(vals, starts))


def _digest(kind: bytes, *arrays: np.ndarray) -> bytes:
    """A key for arrays of float64 (their shapes and bytes)."""
    h = hashlib.blake2b(kind, digest_size=20)
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=np.float64)
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.digest()
