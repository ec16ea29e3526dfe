"""Averages of a field over a disc of the r-z section, weighted by 2 pi r, and their maximum over positions.

The theory of critical distances (Taylor 2007, "The Theory of Critical Distances", the area method)
judges a notched part by its stress averaged over a small named region around the hot spot instead of
the peak: an integral of the field, it has a limit under mesh refinement even at a sharp corner.

The field is the stress or strain at the quadrature points, fitted by least squares with one linear
function (a + b r + c z) per cell (:class:`CellField`), so a field linear in each cell is reproduced
exactly. The average over the disc of radius R centred at (r0, z0) intersected with a region is

    A(r0, z0) = int f 2 pi r dA / int 2 pi r dA   over disc and region,

computed with a fixed product rule on the disc (Gauss-Legendre in the radius with the polar weight,
equally spaced angles), the same points whatever the mesh: on a field the mesh represents exactly the
average is the same on every mesh, and on a polynomial field of degree <= 9 the rule is exact. Points
of the rule that fall outside the region (in the suture, outside the body) are left out of both
integrals. The maximum over positions is a grid search on grids fixed in space (spacing R/4, then
R/16, then R/64 around the best centre so far, each moved while its best centre is on its edge: :data:`GRID_LEVELS`),
over centres inside the region, started from the region's largest point values and from the maxima of
a coarse view of the average over the whole region (:func:`coarse_starts`): fixed grids make it the same
on every mesh and every partition, which a continuous optimiser's path would not be.

The rule only leads the search: the search maximises over centres and so seeks out centres whose rule
points fall on a rim's small hot cells (on the paper scene's sharp rims the rule read the near-cone stress
average 23-52 % above the exact one). The rule's climbs stop at R/4 (its first level), and from each
one's best centre a pattern search on the exact average of the fitted field, from each triangle's overlap with the disc
(:mod:`suture_fem.outputs.disc_cells`), gives the value and centre reported (:func:`max_disc_average`).

Collective: every rank locates the rule's points in its owned cells, the values are reduced with MPI
MAX (a point on an edge between two cells takes the larger value), and every rank then computes the
same averages from the same array.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from suture_fem.outputs.candidates import CANDIDATES, spread, top_points
from suture_fem.outputs.disc_cells import overlap_averages, overlap_climbs
from suture_fem.outputs.disc_points import DiscPoints, Prepared, row_keys
from suture_fem.support import compat

__all__ = ["CellField", "DiscMax", "DiscPoints", "coarse_starts", "disc_averages", "disc_rule",
           "max_disc_average", "overlap_averages", "spread", "top_points"]

#: Points of the disc rule: Gauss-Legendre points in the radius, equally spaced angles.
RADIAL_POINTS, ANGULAR_POINTS = 6, 24
#: Grid search: (spacing, half-width in spacings) of each level, as fractions of the radius.
GRID_LEVELS = ((1 / 4, 4), (1 / 16, 4), (1 / 64, 4))
#: How many of the levels the point rule climbs when the exact average ends the search (:func:`max_disc_average`):
#: the first (R/4) only; the exact pattern search's own levels (R/4 to R/64) place the centre. Climbing the rule's
#: R/16 level too found the same maxima and centres, bit for bit, on the paper scene (1 and 4 cones, P1 and P2)
#: at more CPU (docs/api.md).
RULE_LEVELS_LEADING = 1
#: Largest number of times a level's grid moves toward a better centre on its edge.
MAX_MOVES = 20
#: Largest point values of a region taken as candidate centres (at least R apart), and how many of them,
#: ranked by their own disc average, the search climbs from. Ranking by the average, not by the point
#: value, matters: the largest point values sit at the sharp corners that remain (the cones' apex rims),
#: whose discs average little; with only three starts taken by point value, a P2 r2 mesh of the paper
#: scene at 4 N put all three at apex corners and missed the base rim's disc (235 against 455 kPa).
#: The candidates are of two kinds, up to :data:`CANDIDATES` of each: the largest point values, and the
#: maxima of a coarse view of the disc average over the whole region (:func:`coarse_starts`). The second
#: kind finds a broad concentration that the largest point values miss when a finely meshed corner holds
#: thousands of larger ones (1 cone with a 0.04 mm fillet meshed with 128 elements along it: every one of
#: the 2,400 largest point values was at the fillet and the apex rim, and the thread exit's disc, the
#: largest strain average, was never a candidate: 1.249 instead of 1.381).
STARTS = 3

#: A function of disc centres (k, 2) returning which of them the search may use (a boolean mask (k,)).
Allowed = Callable[[np.ndarray], np.ndarray]


@functools.lru_cache(maxsize=8)
def disc_rule(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(offsets (m, 2), area weights (m,)) of the product rule on a disc of ``radius``; the weights sum to pi R^2."""
    x, w = np.polynomial.legendre.leggauss(RADIAL_POINTS)
    rho = 0.5 * radius * (x + 1.0)
    w_rho = 0.5 * radius * w * rho  # polar Jacobian rho d rho
    theta = 2.0 * np.pi * (np.arange(ANGULAR_POINTS) + 0.5) / ANGULAR_POINTS
    offsets = np.stack([np.outer(rho, np.cos(theta)).ravel(), np.outer(rho, np.sin(theta)).ravel()], axis=1)
    weights = np.repeat(w_rho, ANGULAR_POINTS) * (2.0 * np.pi / ANGULAR_POINTS)
    offsets.flags.writeable = weights.flags.writeable = False  # cached: shared by every caller
    return offsets, weights


class CellField:
    """A field linear in each cell of a set of local owned cells, fitted to its values at points of the cells.

    ``xy`` (n_cells, q, 2) and ``values`` (n_cells, q): the points of each cell and the field there, in
    the mesh's coordinate units. With fewer than 3 points per cell the fit is the cell's mean.
    ``locate``: ``compat.cell_locator(mesh, cells)`` when the caller keeps one for several fields.
    ``coeffs``: the fit of these values, when the caller has it (each cell's fit depends on its own points
    and values alone: the whole tissue's is its layers' fits in order).
    """

    def __init__(self, mesh: Any, cells: np.ndarray, xy: np.ndarray, values: np.ndarray, locate: Any = None,
                 discs: DiscPoints | None = None, coeffs: np.ndarray | None = None):
        self.discs = discs
        self.mesh, self.comm = mesh, mesh.comm
        self._vertex_values: np.ndarray | None = None  # the fit at the cells' vertices (outputs.disc_cells)
        self.cells = np.asarray(cells, dtype=np.int32)
        if discs is not None and discs.cells is not None:  # the same cells and points as the field before
            self.centre, self.row, system = discs.cells
        else:
            self.centre = xy.mean(axis=1) if len(cells) else np.zeros((0, 2))
            num = mesh.topology.index_map(mesh.topology.dim).size_local
            num += mesh.topology.index_map(mesh.topology.dim).num_ghosts
            self.row = np.full(num, -1, dtype=np.int64)
            self.row[self.cells] = np.arange(len(self.cells))
            system = _fit_system(xy - self.centre[:, None, :]) if len(cells) else None
            if discs is not None:
                discs.cells = (self.centre, self.row, system)
        if coeffs is not None:
            self.coeffs = coeffs
        else:
            self.coeffs = _fit(system, values) if system is not None else np.zeros((0, 3))
        self.columns = np.ascontiguousarray(self.coeffs.T)  # (3, n): a, b, c each contiguous, for the gathers
        self.locate = locate if locate is not None else compat.cell_locator(mesh, self.cells)

    def at(self, points: np.ndarray, key: bytes | None = None) -> np.ndarray:
        """The field at points (m, 2); -inf where no cell of the field (on any rank) holds the point (collective).

        With ``discs`` (:class:`DiscPoints`), the points are prepared once and kept for the next field
        (under ``key`` when given: a key that names these points alone, else a digest of them).
        """
        if self.discs is not None:
            prepared = self.discs.prepared_points(points, self.row, self.centre, key)
            return self._reduce(prepared.values(self.columns))
        located = self.locate(np.column_stack([points, np.zeros(len(points))])) if len(points) else None
        return self._reduce(Prepared.of(points, located, self.row, self.centre).values(self.columns))

    def at_discs(self, centres: np.ndarray, offsets: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`at` of ``[centre i, centre i + offsets]`` for each centre (k, m + 1); the rule's weights (collective).

        The weights (k, m) are ``weights * |r|`` of each rule point (the 2 pi r weighting). With ``discs``
        (:class:`DiscPoints`), a centre's points are located and prepared once, for every later field of the
        same cells (another state): the same cells, so the same values, bit for bit.
        """
        if self.discs is None or not len(centres):
            points = np.concatenate([centres[:, None, :], centres[:, None, :] + offsets[None, :, :]], axis=1)
            w = weights[None, :] * np.abs(points[:, 1:, 0])
            return self.at(points.reshape(-1, 2)).reshape(len(centres), -1), w
        prepared, w = self.discs.prepared_discs(centres, offsets, weights, self.row, self.centre)
        return self._reduce(prepared.values(self.columns)).reshape(len(centres), -1), w

    def _reduce(self, local: np.ndarray) -> np.ndarray:
        """The largest of every rank's values (collective)."""
        if self.comm.size == 1:
            return local
        out = np.empty_like(local)
        from mpi4py import MPI

        self.comm.Allreduce(local, out, op=MPI.MAX)
        return out


def _fit_system(d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | tuple[None, None, None]:
    """What the per-cell least-squares fit needs of the points alone: (design matrix, normal matrix, scales).

    (None, None, None) with fewer than 3 points per cell (the fit is then the cell's mean).
    """
    if d.shape[1] < 3:
        return None, None, None
    scale = np.maximum(np.abs(d).max(axis=(1, 2)), 1e-300)[:, None, None]
    a = np.concatenate([np.ones(d.shape[:2] + (1,)), d / scale], axis=2)
    return a, np.einsum("nqi,nqj->nij", a, a), np.concatenate([np.ones((len(d), 1)), scale[:, :, 0].repeat(2, axis=1)],
                                                              axis=1)


def _fit(system: tuple[Any, Any, Any], values: np.ndarray) -> np.ndarray:
    """Per-cell least-squares coefficients (a, b, c) of a + b dr + c dz (offsets from the cell's centre)."""
    a, normal, unscale = system
    if a is None:
        return np.column_stack([values.mean(axis=1), np.zeros((len(values), 2))])
    # right-hand sides as explicit columns: numpy 2 no longer reads a (n, 3) b as n vectors
    coef = np.linalg.solve(normal, np.einsum("nqi,nq->ni", a, values)[..., None])[..., 0]
    return coef / unscale


class DiscMax(NamedTuple):
    """The largest disc average and the centre of its disc; (-inf, None) where the field has no cells."""

    value: float
    at: list[float] | None


def disc_averages(field: CellField, centres: np.ndarray, radius: float, allowed: Allowed | None = None) -> np.ndarray:
    """The 2 pi r-weighted average over each disc around ``centres`` (k, 2) and the field's cells (collective).

    -inf for a centre that no cell of the field holds (the disc is centred outside the region), and for a
    centre that ``allowed`` (a function of centres (k, 2) returning a boolean mask) rules out.
    """
    if allowed is not None:
        centres = np.asarray(centres, dtype=float)
        ok = allowed(centres)
        out = np.full(len(centres), -np.inf)
        if ok.any():  # centres and mask are the same on every rank: collective on all or on none
            out[ok] = disc_averages(field, centres[ok], radius)
        return out
    offsets, weights = disc_rule(radius)
    values, w = field.at_discs(np.asarray(centres, dtype=float).reshape(-1, 2), offsets, weights)
    inside, vals = values[:, 0], values[:, 1:]
    finite = np.isfinite(vals)
    w = np.where(finite, w, 0.0)  # (not in place: the weights may be kept with their batch)
    total = w.sum(axis=1)
    weighted = np.where(finite, vals, 0.0)
    weighted *= w
    avg = np.where(total > 0, np.sum(weighted, axis=1) / np.maximum(total, 1e-300), -np.inf)
    return np.where(np.isfinite(inside), avg, -np.inf)


def max_disc_average(field: CellField, starts: np.ndarray | tuple[np.ndarray, ...], radius: float,
                     allowed: Allowed | None = None, known: dict | None = None, exact: bool = True) -> DiscMax:
    """The largest disc average over centres inside the field's cells (and ``allowed``), by grid search (collective).

    With ``exact`` (the default) the rule climbs :data:`RULE_LEVELS_LEADING` levels and from each climb's best
    centre :func:`~suture_fem.outputs.disc_cells.overlap_climbs` gives the value and centre; without it, the rule's.

    ``starts``: candidate centres (k, 2), the same on every rank, or a tuple of such groups: the search
    climbs from the :data:`STARTS` of each group whose own disc averages are largest, skipping a start
    within R of one taken before it (a group added after one whose starts are R apart, as
    :func:`top_points` gives them, can then only raise the maximum found). ``allowed``: see
    :func:`disc_averages`. ``known``: the averages at grid centres already computed for this field and
    radius (a dict the caller keeps to share them between searches; climbs from nearby starts cross the
    same grid points, fixed in space).
    """
    known = {} if known is None else known
    chosen = []
    for group in starts if isinstance(starts, tuple) else (starts,):
        group = np.asarray(group, dtype=float).reshape(-1, 2)
        if allowed is not None:
            group = group[allowed(group)]
        if len(group):
            chosen.append(group[np.argsort(-_start_averages(field, group, radius, known), kind="stable")[:STARTS]])
    climbs: list[np.ndarray] = []  # a start within R of an earlier one would climb the same hill: skipped
    for s in np.concatenate(chosen) if chosen else ():
        if all(np.hypot(*(s - c)) >= radius for c in climbs):
            climbs.append(s)
    ends = [np.asarray(s, dtype=float) for s in climbs]
    values = [-np.inf] * len(ends)
    for spacing, half in GRID_LEVELS[:RULE_LEVELS_LEADING] if exact else GRID_LEVELS:
        _climbs(field, ends, values, spacing * radius, half, radius, allowed, known)
    best_value, best = -np.inf, None
    for value, centre in zip(values, ends):  # the first of equal maxima, in the climbs' order
        if value > best_value:
            best_value, best = value, [float(c) for c in centre]
    if exact:  # the overlaps' averages under their own keys: the rule's are keyed by integers
        return DiscMax(*overlap_climbs(field, ends, radius, allowed, known.setdefault("overlap", {})))
    return DiscMax(best_value, best)


def _start_averages(field: CellField, group: np.ndarray, radius: float, known: dict) -> np.ndarray:
    """:func:`disc_averages` at candidate centres (k, 2), each computed once per ``known`` (under its bytes)."""
    ranked = known.setdefault("starts", {})
    keys = row_keys(group)
    new = [i for i, k in enumerate(keys) if k not in ranked]
    if new:  # each centre's average is its own: the same in any batch
        ranked.update(zip((keys[i] for i in new), disc_averages(field, group[new], radius).tolist()))
    return np.fromiter(map(ranked.__getitem__, keys), np.float64, len(keys))


def _grid_averages(field: CellField, grid: np.ndarray, radius: float, allowed: Allowed | None,
                   known: dict) -> np.ndarray:
    """:func:`disc_averages` at centres of the fixed grids, each computed once per ``known`` (collective)."""
    unit = radius * GRID_LEVELS[-1][0]  # every level's spacing is a multiple of the finest
    index = np.round(grid / unit).astype(np.int64)
    if np.abs(index).max(initial=0) < 2**31:  # one integer per grid point: cheaper to hash than a pair
        keys = (index[:, 0] * 2**32 + index[:, 1]).tolist()
    else:
        keys = [tuple(k) for k in index.tolist()]
    ok = allowed(grid) if allowed is not None else None
    ok_list = ok.tolist() if ok is not None else None
    # each key once (the grids of several climbs overlap), at its first index: the same on every rank
    first = dict(zip(reversed(keys), range(len(keys) - 1, -1, -1)))
    new = [k for k, i in first.items() if k not in known and (ok_list is None or ok_list[i])]
    if new:
        known.update(zip(new, disc_averages(field, grid[[first[k] for k in new]], radius).tolist()))
    out = np.fromiter(map(known.get, keys, itertools.repeat(-np.inf)), np.float64, len(keys))
    if ok is not None:
        out[~ok] = -np.inf
    return out


def _climbs(field: CellField, centres: list[np.ndarray], values: list[float], h: float, half: int, radius: float,
            allowed: Allowed | None, known: dict) -> None:
    """Each climb's best centre of a (2 half + 1)^2 grid of spacing h fixed in space, moved until the best is inside it.

    ``centres`` and ``values`` (each climb's best so far) are updated in place. The climbs move in step: one
    batch of averages per move of all of them (each centre's average is its own, whatever batch computes
    it), each climb's moves its own, as if climbed alone.
    """
    k = np.arange(-half, half + 1) * h
    k_r, k_z = np.repeat(k, len(k)), np.tile(k, len(k))  # the (2 half + 1)^2 offsets, r slowest
    active = np.arange(len(centres))
    for _ in range(MAX_MOVES):
        if not len(active):
            break
        base = np.round(np.array([centres[i] for i in active]) / h) * h  # grid points fixed in space, not on the mesh
        grids = np.stack([base[:, :1] + k_r, base[:, 1:] + k_z], axis=2)
        every = _grid_averages(field, grids.reshape(-1, 2), radius, allowed, known).reshape(len(active), -1)
        j = np.argmax(every, axis=1)
        best = every[np.arange(len(active)), j]
        better = best > np.array([values[i] for i in active])
        for n in np.flatnonzero(better).tolist():
            values[active[n]], centres[active[n]] = float(best[n]), grids[n, j[n]]
        row, col = np.divmod(j, 2 * half + 1)
        inside = (row > 0) & (row < 2 * half) & (col > 0) & (col < 2 * half)
        active = active[better & ~inside]  # on the window's edge: move on


#: The coarse view's grid spacing (fraction of R) and its stencil: the offsets (in spacings) within R.
#: At most COARSE_NODES nodes: below about 0.03 mm on the paper scene's tissue the spacing is doubled
#: until they fit (the stencil then spans more than R: a coarser view, still fixed in space).
COARSE_SPACING = 1 / 2
COARSE_NODES = 200_000
_STENCIL = [(i, j) for i in range(-2, 3) for j in range(-2, 3) if i * i + j * j <= 4]


def coarse_starts(field: CellField, lo: np.ndarray, hi: np.ndarray, radius: float,
                  count: int = CANDIDATES) -> np.ndarray:
    """Candidate centres from a coarse view of the disc average over the whole box [lo, hi] (collective).

    The field is sampled on a grid fixed in space (spacing R/2) and the 2 pi r-weighted average of the
    samples within R of each node (13 of them) approximates the disc average there, with no regard to
    the mesh: a broad concentration is seen however many larger point values a finely meshed corner
    elsewhere holds. The ``count`` nodes with the largest approximate averages that are local maxima,
    ordered by it, R apart; (k, 2), the same on every rank.
    """
    if not np.all(np.isfinite([*lo, *hi])):  # no point of the region on any rank (the same box on every rank)
        return np.zeros((0, 2))
    key = b"coarse" + np.array([*lo, *hi, radius], dtype=np.float64).tobytes()  # the grid: fixed by box and R
    kept = field.discs.coarse.get(key) if field.discs is not None else None
    nodes = kept[0] if kept is not None else _coarse_nodes(lo, hi, radius)
    values = field.at(nodes.reshape(-1, 2), key=key).reshape(nodes.shape[:2])
    inside = np.isfinite(values)
    if kept is not None and np.array_equal(kept[1], inside):  # the weights depend on where the field is
        w, valid, den = kept[2:]
    else:
        w = np.where(inside, np.abs(nodes[..., 0]), 0.0)
        den = _window_sum(w, _STENCIL, 0.0)
        valid, den = inside & (den > 0), np.maximum(den, 1e-300)
        if field.discs is not None:
            field.discs.coarse[key] = (nodes, inside, w, valid, den)
    avg = _window_sum(w * np.where(inside, values, 0.0), _STENCIL, 0.0)
    avg = np.where(valid, avg / den, -np.inf)
    around = [(i, j) for i in (-1, 0, 1) for j in (-1, 0, 1) if i or j]
    peak = np.isfinite(avg)
    for shifted in _shifts(avg, around, -np.inf):  # no neighbour larger
        peak &= avg >= shifted
    idx = np.flatnonzero(peak)
    return spread(nodes.reshape(-1, 2)[idx[np.argsort(-avg.reshape(-1)[idx], kind="stable")]], radius, count)


def _coarse_nodes(lo: np.ndarray, hi: np.ndarray, radius: float) -> np.ndarray:
    """The coarse view's grid over the box [lo, hi] (n, m, 2): spacing R/2, doubled until it has few enough nodes."""
    h = COARSE_SPACING * radius
    area = max((hi[0] - lo[0]) * (hi[1] - lo[1]), 0.0)
    while area / h**2 > COARSE_NODES:  # a critical distance tiny against the region: a coarser view, bounded cost
        h *= 2.0
    axes = [np.arange(np.floor(lo[d] / h) - 1, np.ceil(hi[d] / h) + 2) * h for d in range(2)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)


def _shifts(a: np.ndarray, offsets: list[tuple[int, int]], fill: float) -> list[np.ndarray]:
    """``a`` at index (k + i, l + j) for every (k, l), for each offset (i, j), ``fill`` beyond its edges (views)."""
    padded = np.full((a.shape[0] + 4, a.shape[1] + 4), fill, dtype=a.dtype)
    padded[2:-2, 2:-2] = a
    return [padded[2 + i: 2 + i + a.shape[0], 2 + j: 2 + j + a.shape[1]] for i, j in offsets]


def _window_sum(a: np.ndarray, offsets: list[tuple[int, int]], fill: float) -> np.ndarray:
    """The sum of ``a`` over the offsets around every index (``fill`` beyond the edges), added in the offsets' order."""
    shifted = _shifts(a, offsets, fill)
    total = shifted[0].copy()
    for view in shifted[1:]:  # as np.sum(shifted, axis=0) adds them, without stacking them first
        total += view
    return total
