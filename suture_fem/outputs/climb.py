"""The pattern search that ends the critical-distance searches: the 2-D disc's and the 3-D ball's exact averages.

Each start is climbed through a sequence of grid spacings (fractions of R, each a multiple of the finest):
at each spacing a grid of 3 points per axis around the climb's centre moves to its best point while that
is better than the climb's best so far and is not the grid's own centre. Centres are integer multiples of
the finest spacing, so a grid point's position and its key in ``known`` are the same whichever grid reached
it. The climbs move in step: one batch of new averages per move of all of them (collective in ``evaluate``),
each climb's moves its own, as if climbed alone.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence

import numpy as np

Allowed = Callable[[np.ndarray], np.ndarray]


def climb(starts: list[np.ndarray], levels: Sequence[float], max_moves: int, unit: float,
          evaluate: Callable[[np.ndarray], np.ndarray], allowed: Allowed | None, known: dict,
          fold: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[float, list[float] | None]:
    """The largest average the climbs from ``starts`` (points) reach: (value, centre), the first of equal maxima.

    ``levels``: the spacings in units of R, the last the finest, ``unit`` = R x that finest; ``evaluate``
    (centres (k, d) in length units): their averages; ``allowed``: which centres may be taken; ``known``:
    averages at grid keys already computed (shared between searches); ``fold``: grid points mapped into the
    searched domain (a symmetry plane).
    """
    if not starts:
        return -np.inf, None
    dim = len(starts[0])
    steps = np.array(list(itertools.product((-1, 0, 1), repeat=dim)), dtype=np.int64)
    own = len(steps) // 2  # the offset (0, ..., 0): the grid's own centre
    at = np.array([np.round(np.asarray(s, dtype=float) / unit).astype(np.int64) for s in starts])
    value = np.full(len(at), -np.inf)
    for level in levels:
        step = int(round(level / levels[-1]))
        active = np.arange(len(at))
        for _ in range(max_moves):
            if not len(active):
                break
            base = np.round(at[active] / step).astype(np.int64) * step
            grid = (base[:, None, :] + steps[None] * step).reshape(-1, dim)  # each climb's grid in turn
            grid = fold(grid) if fold is not None else grid
            ok = allowed(grid * unit) if allowed is not None else None
            avgs = _averages(grid, unit, evaluate, ok, known).reshape(len(active), -1)
            j = np.argmax(avgs, axis=1)
            best = avgs[np.arange(len(active)), j]
            better = best > value[active]  # each climb's moves its own
            moved = active[better]
            value[moved] = best[better]
            at[moved] = grid.reshape(len(active), -1, dim)[better, j[better]]
            active = moved[j[better] != own]  # a neighbour was better: move on
    best_value, best_at = -np.inf, None
    for v, a in zip(value.tolist(), at):  # the first of equal maxima, in the climbs' order
        if v > best_value:
            best_value, best_at = v, [float(c) for c in a * unit]
    return best_value, best_at


def grid_keys(grid: np.ndarray) -> list:
    """One hashable key per integer grid point (rows of ``grid``): an integer when the coordinates are small."""
    dim = grid.shape[1]
    bits = 62 // dim
    if not len(grid) or np.abs(grid).max() >= 2 ** (bits - 1):
        return list(map(tuple, grid.tolist()))
    shifted = grid + 2 ** (bits - 1)  # each coordinate in [0, 2^bits)
    key = shifted[:, 0].copy()
    for d in range(1, dim):
        key |= shifted[:, d] << (bits * d)
    return key.tolist()


def _averages(grid: np.ndarray, unit: float, evaluate: Callable[[np.ndarray], np.ndarray], ok: np.ndarray | None,
              known: dict) -> np.ndarray:
    """The averages at the grid points (-inf where ``ok`` is False), those not ``known`` evaluated once each."""
    keys = grid_keys(grid)
    allowed = ok.tolist() if ok is not None else None
    first = dict(zip(reversed(keys), range(len(keys) - 1, -1, -1)))  # each key at its first index
    new = [k for k, n in first.items() if k not in known and (allowed is None or allowed[n])]
    if new:
        known.update(zip(new, evaluate(grid[[first[k] for k in new]] * unit).tolist()))
    out = np.fromiter(map(known.get, keys, itertools.repeat(-np.inf)), np.float64, len(keys))
    if ok is not None:
        out[~ok] = -np.inf
    return out
