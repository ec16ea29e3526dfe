"""The critical-distance average in 3-D: a cell-wise field averaged over a ball (the 2-D disc's counterpart).

The ball's quadrature rule and the average over the ball's part in a region at given
centres, for a field that is constant on each cell (every stress and strain measure of P1 tetrahedra, whose
deformation gradient is constant per cell), on the half model's mirror image (``mirror_z``: the solid
z <= 0 and its reflection about the symmetry plane z = 0, where a scalar measure is even). The search for the
largest average over positions is :mod:`suture_fem.outputs.ball_search`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: The rule's points: Gauss-Legendre in the radius (weight r^2) and in cos(polar angle), equally spaced azimuths.
RADIAL, POLAR, AZIMUTHAL = 4, 6, 12


def ball_rule(radius: float, radial: int = RADIAL, polar: int = POLAR,
              azimuthal: int = AZIMUTHAL) -> tuple[np.ndarray, np.ndarray]:
    """Offsets (k, 3) from the centre and weights (k,) of a product rule on the ball; the weights sum to its volume.

    Exact for polynomials up to degree 2 * radial - 3 in the radius, 2 * polar - 1 in cos(polar angle) and
    trigonometric ones up to azimuthal - 1 in the azimuth. An even ``polar`` puts no point on the plane z = c
    through the centre.
    """
    t, wt = np.polynomial.legendre.leggauss(radial)
    r, wr = 0.5 * radius * (t + 1.0), 0.5 * radius * wt * (0.5 * radius * (t + 1.0)) ** 2
    mu, wmu = np.polynomial.legendre.leggauss(polar)
    phi = 2.0 * np.pi * np.arange(azimuthal) / azimuthal
    R, MU, PHI = np.meshgrid(r, mu, phi, indexing="ij")
    s = np.sqrt(1.0 - MU**2)
    offsets = np.column_stack([(R * s * np.cos(PHI)).ravel(), (R * s * np.sin(PHI)).ravel(), (R * MU).ravel()])
    weights = (wr[:, None, None] * wmu[None, :, None] * np.full(azimuthal, 2.0 * np.pi / azimuthal)).ravel()
    return offsets, weights


def ball_averages(comm: Any, locate: Any, cell_values: np.ndarray, centres: np.ndarray, radius: float,
                  mirror_z: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The field's average over each ball's part in the region, and that part's volume (collective).

    ``locate``: :func:`suture_fem.support.compat.cell_locator` over the region's owned cells; ``cell_values``:
    the field's value per local cell index (read only at the cells ``locate`` finds). ``centres`` (m, 3), the
    same on every rank. A point on a face shared by two cells (of any ranks) takes their mean. With
    ``mirror_z`` a point with z > 0 is read at its mirror image (x, y, -z). Where no part of a ball lies in the
    region the average is NaN and the volume 0.
    """
    offsets, weights = ball_rule(radius)
    points = (np.asarray(centres, dtype=float)[:, None, :] + offsets[None]).reshape(-1, 3)
    if mirror_z:
        points[:, 2] = -np.abs(points[:, 2])
    idx, cells = locate(points, keep=False)
    values, inside = point_values(comm, idx, np.asarray(cell_values, dtype=float)[cells], len(points))
    return weighted_averages(values.reshape(len(centres), -1), inside.reshape(len(centres), -1), weights)


def point_values(comm: Any, idx: np.ndarray, values: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Each of ``size`` points' value and whether any rank holds it (collective; 0 where none).

    The value is the mean over the (point index ``idx``, cell value ``values``) pairs of every rank.
    """
    from mpi4py import MPI

    both = np.zeros(2 * size)  # the sums, then the counts: one reduction
    sums, counts = both[:size], both[size:]
    np.add.at(sums, idx, values)
    np.add.at(counts, idx, 1.0)
    if comm.size > 1:
        comm.Allreduce(MPI.IN_PLACE, both, op=MPI.SUM)
    return np.where(counts > 0, sums / np.maximum(counts, 1.0), 0.0), counts > 0


def weighted_averages(values: np.ndarray, inside: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(average, volume) per row of the rule's point values (k, m) over the points ``inside``; NaN and 0: none."""
    volume = (inside * weights).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        averages = np.where(volume > 0, (values * weights).sum(axis=1) / volume, np.nan)
    return averages, volume
