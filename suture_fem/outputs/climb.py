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
    steps = np.array(list(itertools.product((-1, 0, 1), repeat=len(starts[0]))), dtype=np.int64)
    own = len(steps) // 2  # the offset (0, ..., 0): the grid's own centre
    at = [np.round(np.asarray(s, dtype=float) / unit).astype(np.int64) for s in starts]
    value = [-np.inf] * len(at)
    for level in levels:
        step = int(round(level / levels[-1]))
        active = list(range(len(at)))
        for _ in range(max_moves):
            if not active:
                break
            base = np.round(np.array([at[i] for i in active]) / step).astype(np.int64) * step
            grid = (base[:, None, :] + steps[None] * step).reshape(-1, steps.shape[1])  # each climb's grid in turn
            grid = fold(grid) if fold is not None else grid
            ok = (allowed(grid * unit) if allowed is not None else np.ones(len(grid), dtype=bool)).tolist()
            keys = list(map(tuple, grid.tolist()))
            new: dict = {}  # each key not known once, at its first index
            for n, k in enumerate(keys):
                if ok[n] and k not in known:
                    new.setdefault(k, n)
            if new:
                known.update(zip(new, evaluate(grid[list(new.values())] * unit).tolist()))
            avgs = np.array([known[k] if o else -np.inf for k, o in zip(keys, ok)]).reshape(len(active), -1)
            still = []
            for i, j, row, g in zip(active, np.argmax(avgs, axis=1).tolist(), avgs, grid.reshape(len(active), -1,
                                                                                             grid.shape[1])):
                if row[j] > value[i]:
                    value[i], at[i] = float(row[j]), g[j]
                    if j != own:  # a neighbour was better: move on
                        still.append(i)
            active = still
    best_value, best = -np.inf, None
    for v, a in zip(value, at):  # the first of equal maxima, in the climbs' order
        if v > best_value:
            best_value, best = v, [float(c) for c in a * unit]
    return best_value, best
