"""The disc average of a per-cell linear field from each triangle's overlap with the disc, weighted by 2 pi r.

The 2-D counterpart of :mod:`suture_fem.outputs.ball_cells`. A field linear on each triangle is
f = sum_k f_k phi_k (f_k its values at the vertices, phi_k the barycentric coordinates), and so is r, so

    int_{T n D} f 2 pi r dA = sum_k f_k w_k,   w_k = 2 pi sum_l r_l int_{T n D} phi_k phi_l dA,

with weights w_k that depend on the mesh, the disc and the cell alone: kept per disc, every later field and
state only reads its vertex values there. The average over the disc's part in the region is
sum f_k w_k / sum w_k over the region's cells. A triangle whose three vertices lie in the disc is inside it
(the disc is convex): int_T phi_k phi_l dA = |T| (1 + delta_kl) / 12. A triangle farther from the centre
than R plus its reach is outside. A triangle the circle may cut gets the moments (of 1, x, y, x^2, xy, y^2)
of its part in the disc in closed form (:func:`cut_moments`): the signed sum over its edges AB of the
part of the triangle (centre, A, B) in the disc, which is triangles with the centre as a vertex (the
edge-midpoint rule, exact for quadratics) and circular sectors (closed-form trigonometric integrals). So
the average of the fitted field is exact up to round-off, however the cells are cut; the point rule's is
not (each of its points weighs a fixed share of the disc, whatever cell it falls in, and the search over
centres seeks out the points that fall on a hot spot). Hand-written, with the ball's helpers (cells
grouped by reach, scipy's k-d tree over their centroids: :mod:`suture_fem.outputs.ball_cells`).

:func:`overlap_averages`: the averages (collective: each rank sums its own cells, the sums are reduced).
:func:`overlap_climbs`: the search's last stage, a pattern search on these averages from the point rule's maxima.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np

from suture_fem.outputs.ball_cells import near_cells, reach_groups, reduced_averages
from suture_fem.outputs.climb import climb
from suture_fem.outputs.disc_points import Table, ranges, row_keys
from suture_fem.support import compat

#: Most (disc, cell) pairs whose weights are kept for later fields and states (40 bytes each: 40 MB per region), and
#: most pairs of batches of centres kept gathered (as many again).
KEPT_PAIRS = 1_000_000
#: The last stage's pattern search: the spacings of its 3 x 3 grids (fractions of R, each a multiple of the last;
#: the finest is the point rule's search's finest) and the largest number of moves per spacing.
LEVELS = (1 / 4, 1 / 8, 1 / 16, 1 / 32, 1 / 64)
MAX_MOVES = 20


class DiscOverlap:
    """Vertex weights of discs of ``radius`` on triangles ``vertices`` (n, 3, 2) (r, z), this rank's cells."""

    def __init__(self, vertices: np.ndarray, radius: float):
        self.x, self.radius = np.asarray(vertices, dtype=float).reshape(-1, 3, 2), radius
        self.centroids = self.x.mean(axis=1)
        e = self.x[:, 1:] - self.x[:, :1]
        self.area = 0.5 * np.abs(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
        self.reach = np.linalg.norm(self.x - self.centroids[:, None], axis=2).max(axis=1)
        self.groups = reach_groups(self.centroids, self.reach, radius) if len(self.x) else []
        self.whole = (1.0 + np.eye(3)) / 12.0  # int_T phi_k phi_l dA / |T|
        #: per centre kept (``index``: its bytes to its number): its pairs in ``pairs`` from ``start``, ``count`` of
        #: them, and ``held``: 1.0 where one of the cells holds the centre (:meth:`both`), else 0.0
        self.index: dict[bytes, int] = {}
        self.centres = Table(start=np.int64, count=np.int64, held=np.float64)
        #: per (disc, cell) pair of a kept disc: the cell, its vertex weights w_k (3) and their sum
        self.pairs = Table(cells=np.intp, w=(np.float64, 3), w_sum=np.float64)
        self._offsets: tuple[np.ndarray, np.ndarray] | None = None  # a fit's cell centres, the vertices' offsets
        #: per batch of centres asked for again (its bytes): its pairs gathered, up to KEPT_PAIRS pairs in all
        self.batches: dict[bytes, tuple[np.ndarray, ...]] = {}
        self.batched = 0

    def weights(self, centres: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per centre (k, 2): (cells, vertex weights (m, 3) with a positive sum) of its disc: see the module."""
        centres = np.asarray(centres, dtype=float).reshape(-1, 2)
        ids, sizes = self._numbers(centres, None)
        pairs, start, count = self.pairs, self.centres.start[ids], self.centres.count[ids]
        out = [(pairs.cells[a:a + n].copy(), pairs.w[a:a + n].copy()) for a, n in zip(start.tolist(), count.tolist())]
        if sizes is not None:
            self._truncate(sizes)
        return out

    def both(self, vertex_values: np.ndarray, centres: np.ndarray, locate: Any) -> np.ndarray:
        """(m, 3): this rank's int f 2 pi r dA and int 2 pi r dA per disc, and 1.0 where a cell holds its centre.

        From the cells' vertex values (n, 3); ``locate``: the cells' locator. Each centre's cells and weights are
        computed once (the centres not kept together: one :func:`cut_moments` for all their cut cells) and kept,
        up to :data:`KEPT_PAIRS` (cell, disc) pairs in all; a batch gathers its centres' pairs, and a batch asked
        for again (a pattern search from where an earlier answer's was) reuses them, up to as many pairs again.
        """
        key = centres.tobytes()
        batch = self.batches.get(key)
        if batch is None:
            ids, sizes = self._numbers(centres, locate)
            count = self.centres.count[ids]
            has = count > 0  # reduceat: each centre's cells, from its first (none: skipped)
            take = ranges(self.centres.start[ids], count)
            batch = (self.pairs.cells[take], self.pairs.w[take], self.pairs.w_sum[take], has,
                     (np.cumsum(count) - count)[has], self.centres.held[ids])
            if sizes is not None:
                self._truncate(sizes)
            elif self.batched + len(take) <= KEPT_PAIRS:
                self.batches[key], self.batched = batch, self.batched + len(take)
        cells, w, w_sum, has, first, held = batch
        out = np.zeros((len(centres), 3))
        out[:, 2] = held
        if len(cells):
            per_cell = np.stack([np.einsum("nk,nk->n", vertex_values[cells], w), w_sum], axis=1)
            out[has, :2] = np.add.reduceat(per_cell, first, axis=0)
        return out

    def vertex_offsets(self, centre: np.ndarray) -> np.ndarray:
        """The cells' vertices' offsets (n, 3, 2) from a fit's cell centres ``centre`` (n, 2) (kept per array)."""
        if self._offsets is None or self._offsets[0] is not centre:
            self._offsets = (centre, self.x - centre[:, None, :])
        return self._offsets[1]

    def _numbers(self, centres: np.ndarray, locate: Any) -> tuple[np.ndarray, tuple[int, int] | None]:
        """The centres' numbers, the new ones added; the tables' sizes to go back to when they were not to be kept.

        ``locate`` None: whether a cell holds a new centre is not asked (0.0).
        """
        keys = row_keys(centres)
        ids = np.fromiter(map(self.index.get, keys, itertools.repeat(-1)), np.int64, len(keys))
        if not len(ids) or ids.min() >= 0:
            return ids, None
        first: dict[bytes, int] = {}  # each new centre once, at its first index
        for i in np.flatnonzero(ids < 0).tolist():
            first.setdefault(keys[i], i)
        sizes = self.centres.size, self.pairs.size
        found = dict(zip(first, self._add(centres[list(first.values())], locate).tolist()))
        ids = np.fromiter((found[k] if v < 0 else v for k, v in zip(keys, ids.tolist())), np.int64, len(keys))
        if self.pairs.size > KEPT_PAIRS or locate is None:
            return ids, sizes
        self.index.update(found)
        return ids, None

    def _truncate(self, sizes: tuple[int, int]) -> None:
        self.centres.resize(sizes[0])
        self.pairs.resize(sizes[1])

    def _add(self, centres: np.ndarray, locate: Any) -> np.ndarray:
        """Add new centres (k, 2): their cells, weights and whether a cell holds them; their numbers (k,)."""
        k = len(centres)
        parts = [np.concatenate(near_cells(self.groups, c, self.radius)) if self.groups else np.zeros(0, np.int64)
                 for c in centres]
        counts = np.array([len(p) for p in parts], dtype=np.int64)
        near = np.concatenate(parts) if parts else np.zeros(0, np.int64)
        w = self._weights(np.repeat(centres, counts, axis=0), near)
        keep = w.sum(axis=1) > 0
        count = np.bincount(np.repeat(np.arange(k), counts)[keep], minlength=k)
        held = np.zeros(k)
        if locate is not None and k:
            idx, _ = locate(np.column_stack([centres, np.zeros(k)]), keep=False)
            held[idx] = 1.0
        base = self.pairs.append(cells=near[keep], w=w[keep], w_sum=w[keep].sum(axis=1))
        start = self.centres.append(start=base + np.cumsum(count) - count, count=count, held=held)
        return np.arange(start, start + k)

    def _weights(self, c: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """w_k (n, 3) of the discs at c (n, 2) on cells (n,): whole, 0 outside, cut ones by :func:`cut_moments`."""
        d = self.x[cells] - c[:, None, :]
        inside = ((d**2).sum(axis=2) <= self.radius**2).all(axis=1)
        apart = np.linalg.norm(self.centroids[cells] - c, axis=1) - self.reach[cells] > self.radius
        w = np.zeros((len(cells), 3))
        r = self.x[cells, :, 0]
        w[inside] = np.einsum("kl,nl->nk", self.whole, r[inside]) * self.area[cells[inside], None]
        cut = np.flatnonzero(~inside & ~apart)
        if len(cut):
            m0, m1, m2 = cut_moments(d[cut], self.radius)
            ones = np.ones((len(cut), 3, 1))  # phi_k = alpha_k + beta_k . x: the inverse of [1, x_j] (rows j)
            coef = np.linalg.inv(np.concatenate([ones, d[cut]], axis=2))  # (n, 3: alpha, beta_r, beta_z; 3: k)
            r_c = c[cut, 0]
            r_int = r_c * m0 + m1[:, 0]  # int r dA and int x r dA (x from the centre), r = c_r + x_r
            x_r_int = r_c[:, None] * m1 + m2[:, :, 0]
            w[cut] = coef[:, 0] * r_int[:, None] + np.einsum("nik,ni->nk", coef[:, 1:], x_r_int)
        return 2.0 * np.pi * w


def cut_moments(x: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Moments of the part of each triangle x (n, 3, 2) (coordinates from the disc's centre) in the disc.

    (int 1 dA (n,), int x dA (n, 2), int x x^T dA (n, 2, 2)), exact up to round-off: see the module.
    """
    a, e = x, np.roll(x, -1, axis=1) - x  # the edges A -> B = A + e
    ee, ae, aa = (e * e).sum(-1), (a * e).sum(-1), (a * a).sum(-1) - radius**2
    disc = ae**2 - ee * aa  # |A + t e|^2 = R^2: t = (-ae -+ sqrt(disc)) / ee
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        t1, t2 = (np.clip((-ae + s * root) / ee, 0.0, 1.0) for s in (-1.0, 1.0))
    hit = (disc > 0) & (t2 > t1) & (ee > 0)
    t1, t2 = np.where(hit, t1, 1.0), np.where(hit, t2, 1.0)  # no chord: the sector from A to B alone
    p, q = a + t1[..., None] * e, a + t2[..., None] * e
    m = [sum(parts) for parts in zip(_sector(a, p, radius), _triangle(p, q), _sector(q, a + e, radius))]
    m = [part.sum(axis=1) for part in m]  # the three edges
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    sign = np.sign(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])  # a clockwise triangle's sums are negative
    return m[0] * sign, m[1] * sign[:, None], m[2] * sign[:, None, None]


def _sector(u: np.ndarray, v: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed moments of the disc's sector from the direction of u to that of v (..., 2) (under a half turn)."""
    ta = np.arctan2(u[..., 1], u[..., 0])
    span = np.arctan2(u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0], (u * v).sum(-1))
    tb = ta + span
    sa, ca, sb, cb = np.sin(ta), np.cos(ta), np.sin(tb), np.cos(tb)
    m0 = radius**2 / 2 * span
    m1 = radius**3 / 3 * np.stack([sb - sa, ca - cb], axis=-1)
    half = (np.sin(2 * tb) - np.sin(2 * ta)) / 4  # int cos^2 = span / 2 + half, int sin^2 = span / 2 - half
    cross = (sb**2 - sa**2) / 2  # int sin cos
    m2 = radius**4 / 4 * np.stack([np.stack([span / 2 + half, cross], -1), np.stack([cross, span / 2 - half], -1)], -2)
    return m0, m1, m2


def _triangle(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed moments of the triangles (0, p, q) (..., 2): the edge-midpoint rule, exact for quadratics."""
    area = (p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0]) / 2
    mids = np.stack([p / 2, q / 2, (p + q) / 2], axis=-2)
    m2 = np.einsum("...ji,...jk->...ik", mids, mids) * (area / 3)[..., None, None]
    return area, (p + q) / 3 * area[..., None], m2


def field_overlap(field: Any, radius: float) -> tuple[DiscOverlap, np.ndarray]:
    """A :class:`~suture_fem.outputs.disc.CellField`'s :class:`DiscOverlap` (kept with its ``discs``), vertex values."""
    kept = field.discs.overlaps if field.discs is not None else field.__dict__.setdefault("_overlaps", {})
    if radius not in kept:
        mesh = field.mesh
        vertices = mesh.geometry.x[:, :2][compat.geometry_dofs(mesh)[field.cells, :3]]
        kept[radius] = DiscOverlap(vertices.reshape(-1, 3, 2), radius)
    overlap = kept[radius]
    if getattr(field, "_vertex_values", None) is None:  # a + b dr + c dz at each vertex, dr, dz from the cell's centre
        d = overlap.vertex_offsets(field.centre)
        a, b, c = (field.coeffs[:, i:i + 1] for i in range(3))
        field._vertex_values = a + b * d[..., 0] + c * d[..., 1]
    return overlap, field._vertex_values


def overlap_averages(field: Any, centres: np.ndarray, radius: float,
                     allowed: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """The 2 pi r-weighted average over each disc's part in the field's cells, from the cells' overlaps (collective).

    As :func:`suture_fem.outputs.disc.disc_averages`: -inf for a centre no cell holds or ``allowed`` rules out.
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    if allowed is not None:
        out = np.full(len(centres), -np.inf)
        ok = allowed(centres)
        if ok.any():  # centres and mask are the same on every rank: collective on all or on none
            out[ok] = overlap_averages(field, centres[ok], radius)
        return out
    if not len(centres):
        return np.full(0, -np.inf)
    if not len(field.cells):
        return reduced_averages(field.comm, np.zeros((len(centres), 3)))
    overlap, values = field_overlap(field, radius)
    return reduced_averages(field.comm, overlap.both(values, centres, field.locate))


def overlap_climbs(field: Any, starts: list[np.ndarray], radius: float, allowed: Any,
                   known: dict) -> tuple[float, list[float] | None]:
    """The largest :func:`overlap_averages` found by a pattern search from each start: (value, centre) (collective).

    Each start (the point rule's best centre of one of its climbs) is climbed through the :data:`LEVELS` by
    :func:`~suture_fem.outputs.climb.climb` (3 x 3 grids fixed in space). ``known``: the averages at grid
    centres already computed (shared between searches). A local search: the average of a field fitted per
    cell has small local maxima where the circle crosses a rim's small cells (1 cone, P2 r1: a scan at R/32
    found one 0.4 % above the value found, R/5 away; docs/three-d.md).
    """
    return climb(starts, LEVELS, MAX_MOVES, radius * LEVELS[-1], lambda c: overlap_averages(field, c, radius),
                 allowed, known)
