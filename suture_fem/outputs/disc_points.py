"""What the disc averages of :mod:`suture_fem.outputs.disc` keep between fields: located and prepared points.

Where a point falls among a region's cells, the cell's row in a fitted field's coefficients and the
point's offset from the cell's centre depend on the mesh, the region's cells and the point only, not on
the field's values. The critical-distance searches ask for the same points again and again: grids fixed
in space, at every reported force, for every quantity, and in every later answer of a
:class:`suture_fem.Model`. :class:`DiscPoints` keeps, per region:

* per disc centre, its points prepared for evaluation (:class:`_Pool`: the (point, cell) pairs of its
  centre and its rule points, each cell's row in the fitted coefficients and the point's offset from the
  cell's centre), so a new batch of centres is a gather from these, whatever other centres it holds;
* per batch of points asked for (a batch of disc centres with its rule weights, a coarse view's grid), the
  points prepared (:class:`Prepared`), for the same batch again: on the paper scene (P1 r0) 55-70 % of a
  later answer's disc centres come in a batch an earlier answer asked for, the rest mostly in new batches
  of centres asked for before (docs/api.md),

so that a field's values there are a few numpy operations (:meth:`Prepared.values`), the same operations
in the same order as without them: the same numbers, bit for bit.

No communication: each rank keeps its own cells.
"""

from __future__ import annotations

import hashlib
import itertools
from collections import OrderedDict
from typing import Any, NamedTuple

import numpy as np


class Prepared(NamedTuple):
    """Points of a field's cells ready for evaluation: everything that does not depend on the field's values.

    ``size`` points; per (point, cell) pair, sorted by point: the point's index ``idx``, the cell's row
    ``rows`` in the coefficients and the point's offset ``d0``, ``d1`` from the cell's centre;
    ``starts`` (None: ``idx`` not sorted) the first pair of each point and ``group`` that point (with
    them ``idx`` may be None: the points of a :class:`_Pool`'s batch).
    """

    size: int
    idx: np.ndarray | None
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
        if not len(self.rows):
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
    Each disc centre's points are prepared once (:class:`_Pool`: its pairs' rows and offsets and which of its
    points a cell holds, about 4 kB a centre) and a new batch of centres is gathered from them; up to ``limit``
    (point, cell) pairs are kept per rule (beyond it, new centres are prepared for their batch alone).
    Prepared batches (of disc centres, with their rule weights, and a coarse view's grid) are kept up to
    ``batch_bytes`` (the least recently used one goes first).
    """

    def __init__(self, locate: Any, limit: int = 2_000_000, batch_bytes: int = 32 * 2**20):
        self.locate, self.limit, self.batch_bytes = locate, limit, batch_bytes
        #: per rule (its offsets' bytes), the prepared points of every disc centre asked for
        self.pools: dict[bytes, _Pool] = {}
        #: the fields' cell centres, rows and least-squares system (they too depend on the points alone)
        self.cells: tuple[np.ndarray, np.ndarray, Any] | None = None
        #: prepared batches asked for again (a batch of disc centres with its rule weights, a coarse view's grid)
        self.batches: OrderedDict[bytes, tuple[Prepared, np.ndarray | None]] = OrderedDict()
        #: per coarse view (its key): its grid, where the field was, the 2 pi r weights, where their window sums are
        #: positive and those sums (at least 1e-300)
        self.coarse: dict[bytes, tuple[np.ndarray, ...]] = {}
        #: per radius, the cells' overlaps with discs (:class:`~suture_fem.outputs.disc_cells.DiscOverlap`)
        self.overlaps: dict[float, Any] = {}
        self._bytes = 0

    def prepared_discs(self, centres: np.ndarray, offsets: np.ndarray, weights: np.ndarray, row: np.ndarray,
                       centre: np.ndarray) -> tuple[Prepared, np.ndarray]:
        """The points of each disc, ``[centre i, centre i + offsets]`` in turn, prepared; the rule's weights (k, m).

        The weights are ``weights * |r|`` of each rule point (the 2 pi r weighting). The points of centre i
        are numbered i (m + 1) (the centre) to i (m + 1) + m (its rule points).
        """
        centres = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 2)
        key = _digest(b"discs", offsets, centres)
        if key in self.batches:  # the same batch again (a climb from where an earlier answer's climb was)
            self.batches.move_to_end(key)
            return self.batches[key]
        prepared, w = self._pooled(centres, offsets, row, centre), _rule_weights(centres, offsets, weights)
        return self._keep(key, prepared, w)

    def _pooled(self, centres: np.ndarray, offsets: np.ndarray, row: np.ndarray, centre: np.ndarray) -> Prepared:
        """:meth:`prepared_discs`'s points gathered from the centres' own (new centres prepared first)."""
        tag = offsets.tobytes()
        if tag not in self.pools:
            self.pools[tag] = _Pool(np.ascontiguousarray(offsets, dtype=np.float64))
        pool = self.pools[tag]
        keys = row_keys(centres)
        ids = np.fromiter(map(pool.index.get, keys, itertools.repeat(-1)), np.int64, len(keys))
        if len(ids) and ids.min() < 0:
            first: dict[bytes, int] = {}  # each new centre once, at its first index
            for i in np.flatnonzero(ids < 0).tolist():
                first.setdefault(keys[i], i)
            size = pool.sizes()
            new_ids = pool.add(centres[list(first.values())], row, centre, self.locate)
            found = dict(zip(first, new_ids.tolist()))
            ids = np.fromiter((found[k] if v < 0 else v for k, v in zip(keys, ids.tolist())), np.int64, len(keys))
            if pool.pairs.size <= self.limit:
                pool.index.update(found)
            else:  # prepared for this batch alone
                prepared = pool.gather(ids)
                pool.truncate(size)
                return prepared
        return pool.gather(ids)

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
        """Keep a prepared batch (the least recently used ones go while the batches would exceed their bytes)."""
        size = prepared.nbytes + (w.nbytes if w is not None else 0)
        while self.batches and self._bytes + size > self.batch_bytes:
            _, (old, old_w) = self.batches.popitem(last=False)
            self._bytes -= old.nbytes + (old_w.nbytes if old_w is not None else 0)
        if size <= self.batch_bytes:
            self.batches[key] = (prepared, w)
            self._bytes += size
        return prepared, w


def _rule_weights(centres: np.ndarray, offsets: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The rule's 2 pi r weights (k, m) of the discs at ``centres``: weight times |r| of each rule point."""
    return weights[None, :] * np.abs(centres[:, :1] + offsets[None, :, 0])


class Table:
    """Columns of equal length that grow (their capacity doubled), read as attributes of length ``size``.

    Each column is a dtype, or (dtype, width) for rows of ``width`` values.
    """

    def __init__(self, **dtypes: Any):
        self.cols: dict[str, np.ndarray] = {}
        for name, d in dtypes.items():
            dtype, width = d if isinstance(d, tuple) else (d, None)
            self.cols[name] = np.empty((1024,) if width is None else (1024, width), dtype=dtype)
        self.resize(0)

    def append(self, **values: np.ndarray) -> int:
        """Append the columns' new values (every column); the index of the first."""
        start = self.size
        end = start + len(next(iter(values.values())))
        capacity = len(next(iter(self.cols.values())))
        if end > capacity:
            capacity = max(end, 2 * capacity)
            for name, old in self.cols.items():
                self.cols[name] = np.empty((capacity, *old.shape[1:]), dtype=old.dtype)
                self.cols[name][:start] = old[:start]
        for name, v in values.items():
            self.cols[name][start:end] = v
        self.resize(end)
        return start

    def resize(self, size: int) -> None:
        """Keep the first ``size`` rows (at most those appended): each column is an attribute of that length."""
        self.size = size
        for name, col in self.cols.items():
            setattr(self, name, col[:size])

    @property
    def nbytes(self) -> int:
        """Memory held (bytes)."""
        return sum(a.nbytes for a in self.cols.values())


class _Pool:
    """The prepared points of disc centres of one rule (``offsets`` (m, 2)), centre by centre.

    Per centre (``index``: its bytes to its number), its (point, cell) pairs in ``pairs`` from ``start``,
    ``count`` of them: the point's number in the disc (0: the centre, 1 + j: rule point j), the cell's row,
    the point's offsets from the cell's centre and whether the pair is its point's first; in the locator's
    order (points in order). The same pairs and offsets :meth:`Prepared.of` computes for a batch.
    """

    def __init__(self, offsets: np.ndarray):
        self.offsets = offsets
        self.index: dict[bytes, int] = {}
        #: per centre: its first pair, how many, and which of its m + 1 points a cell holds
        self.centres = Table(start=np.int64, count=np.int64, located=(bool, len(offsets) + 1))
        self.pairs = Table(rows=np.intp, d0=np.float64, d1=np.float64, first=bool)

    def sizes(self) -> tuple[int, int]:
        """The tables' sizes (for :meth:`truncate`)."""
        return self.centres.size, self.pairs.size

    def truncate(self, sizes: tuple[int, int]) -> None:
        """Forget the centres added since :meth:`sizes` gave ``sizes``."""
        self.centres.resize(sizes[0])
        self.pairs.resize(sizes[1])

    def add(self, centres: np.ndarray, row: np.ndarray, centre: np.ndarray, locate: Any) -> np.ndarray:
        """Prepare new centres (k, 2) (rows and centres of the fields' cells); their numbers (k,)."""
        k, m = len(centres), len(self.offsets)
        points = np.concatenate([centres[:, None, :], centres[:, None, :] + self.offsets[None, :, :]], axis=1)
        points = points.reshape(-1, 2)
        idx, cells = locate(np.column_stack([points, np.zeros(len(points))]), keep=False)
        rows = row[cells]
        d = points[idx] - centre[rows]
        first = np.r_[True, idx[1:] != idx[:-1]] if len(idx) else np.zeros(0, dtype=bool)
        count = np.bincount(idx // (m + 1), minlength=k)
        located = np.zeros((k, m + 1), dtype=bool)
        located.reshape(-1)[idx] = True
        base = self.pairs.append(rows=rows, d0=d[:, 0], d1=d[:, 1], first=first)
        start = self.centres.append(start=base + np.cumsum(count) - count, count=count, located=located)
        return np.arange(start, start + k)

    def gather(self, ids: np.ndarray) -> Prepared:
        """The points of the centres numbered ``ids``, prepared (point i (m + 1) + p: point p of disc i)."""
        take = ranges(self.centres.start[ids], self.centres.count[ids])
        pairs = self.pairs
        group = np.flatnonzero(self.centres.located[ids])  # the points a cell holds, in order
        return Prepared(len(ids) * (len(self.offsets) + 1), None, pairs.rows[take], pairs.d0[take], pairs.d1[take],
                        np.flatnonzero(pairs.first[take]), group)


def row_keys(rows: np.ndarray) -> list[bytes]:
    """The bytes of each row of a float array (k, d): ``[row.tobytes() for row in rows]``, at once."""
    rows = np.ascontiguousarray(rows, dtype=np.float64)
    return rows.view(np.dtype((np.void, rows.itemsize * rows.shape[1]))).ravel().tolist() if rows.size else []


def ranges(first: np.ndarray, count: np.ndarray) -> np.ndarray:
    """``first[i], first[i] + 1, ..., first[i] + count[i] - 1`` for each i in turn, as one array (one running sum)."""
    ends = np.cumsum(count)
    total = int(ends[-1]) if len(ends) else 0
    if total == 0:
        return np.zeros(0, dtype=np.int64)
    some = count > 0
    f, c, at = first[some], count[some], (ends - count)[some]  # at[0] is 0
    step = np.ones(total, dtype=np.int64)
    step[0] = f[0]
    step[at[1:]] = f[1:] - (f[:-1] + c[:-1] - 1)
    return np.cumsum(step)


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
