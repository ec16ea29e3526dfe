"""Candidate centres of the critical-distance searches: the largest point values, at least a distance apart.

:func:`top_points` takes the largest point values over all ranks; :func:`spread` keeps, in order, those at
least a separation from every one kept before (the greedy choice of :mod:`suture_fem.outputs.disc`'s starts
and of the coarse view's maxima). The search's rules for them are in :mod:`suture_fem.outputs.disc`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: Largest point values of a region taken as candidate centres (at least R apart): see :mod:`suture_fem.outputs.disc`.
CANDIDATES = 48
#: Candidates compared with each other at once by :func:`spread` (a block's pairs: 4,096 distances; a row's
#: bits are one 64-bit integer).
SPREAD_BLOCK = 64


def top_points(comm: Any, values: np.ndarray, xy: np.ndarray, separation: float, count: int = CANDIDATES) -> np.ndarray:
    """The ``count`` largest point values over all ranks, at least ``separation`` apart: their (k, 2) positions."""
    order = _largest(values, 50 * count)
    local = np.column_stack([values[order], xy[order]]) if len(order) else np.zeros((0, 3))
    merged = np.concatenate(comm.allgather(local)) if comm.size > 1 else local
    return spread(merged[_descending(merged)][:, 1:], separation, count)


def _descending(rows: np.ndarray) -> np.ndarray:
    """The order of rows (value, r, z) by value, then r, then z, each largest first: ``np.lexsort`` of the negatives.

    A stable sort of the values alone gives that order when no two values are equal and none is NaN (the
    lexsort then never reads r or z); otherwise the lexsort itself.
    """
    key = -rows[:, 0]
    order = np.argsort(key, kind="stable")
    ranked = key[order]
    if np.any(ranked[1:] == ranked[:-1]) or np.isnan(key).any():
        return np.lexsort((-rows[:, 2], -rows[:, 1], key))
    return order


def _largest(values: np.ndarray, n: int) -> np.ndarray:
    """Indices of the ``n`` largest values (in any order): the set ``np.argsort(values)[::-1][:n]`` takes.

    A partition, not a sort (the caller sorts what every rank sends); where a tie at the n-th value
    leaves the set to the sort's order, or with NaN, the sort's own choice is taken.
    """
    if len(values) <= n:
        return np.argsort(values)[::-1]
    top = np.argpartition(values, len(values) - n)[len(values) - n:]
    cut = values[top].min()
    if np.isfinite(cut) and np.count_nonzero(values >= cut) == n and not np.isnan(values).any():
        return top
    return np.argsort(values)[::-1][:n]


def spread(candidates: np.ndarray, separation: float, count: int) -> np.ndarray:
    """The first ``count`` of candidates (k, 2), in order, each at least ``separation`` from those taken before it.

    The candidates are read in blocks of :data:`SPREAD_BLOCK`: those of a block near one taken before are
    struck out (:func:`_near`), then the distances within the block decide, in order, which of the rest are
    taken (as bit masks). Every distance is a later candidate's coordinates minus an earlier one's, as one
    comparison at a time computes it, and a distance that is not ``>= separation`` (NaN too) strikes: the
    choice of a loop over the candidates, in a few numpy operations per block.
    """
    candidates = np.asarray(candidates, dtype=float).reshape(-1, 2)
    r, z = candidates[:, 0].copy(), candidates[:, 1].copy()
    taken: list[int] = []
    for first in range(0, len(candidates), SPREAD_BLOCK):
        if len(taken) >= count:
            break
        block = np.arange(first, min(first + SPREAD_BLOCK, len(candidates)))
        if taken:
            block = block[~_near(r[block] - r[taken][:, None], z[block] - z[taken][:, None], separation)]
        rb, zb = r[block], z[block]
        near = np.zeros((len(block), SPREAD_BLOCK), dtype=bool)  # [a, b]: b's coordinates minus a's
        near[:, :len(block)] = ~(np.hypot(rb[None, :] - rb[:, None], zb[None, :] - zb[:, None]) >= separation)
        masks = np.packbits(near, axis=1, bitorder="little").view("<u8")[:, 0].tolist()  # bit b of row a
        struck = 0
        for a in range(len(block)):
            if not (struck >> a) & 1:  # a candidate before a is struck by a only if a is taken: masks above a
                taken.append(int(block[a]))
                if len(taken) == count:
                    break
                struck |= masks[a]
    return candidates[taken].reshape(-1, 2)


def _near(dr: np.ndarray, dz: np.ndarray, separation: float) -> np.ndarray:
    """Per column of the differences (k, m): whether any ``np.hypot(dr, dz) >= separation`` is false.

    ``np.hypot`` only where both |dr| and |dz| are not ``>= separation``: elsewhere the distance is at least
    that (a hypotenuse rounded within an ulp is no shorter than a side, itself a float), so it is ``>=`` too.
    """
    box = ~(np.abs(dr) >= separation) & ~(np.abs(dz) >= separation)
    near = np.zeros(dr.shape, dtype=bool)
    near[box] = ~(np.hypot(dr[box], dz[box]) >= separation)
    return near.any(axis=0)
