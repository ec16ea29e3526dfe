"""Richardson extrapolation with the observed order, and the two-rung error of ``run --error-estimate``.

For a quantity Q computed on a ladder of meshes with sizes h, h/2, h/4, if Q_h = Q + C h^p + ..., the
last three rungs give

    p = log2((Q_{h/2} - Q_h) / (Q_{h/4} - Q_{h/2})),   Q ~ Q_{h/4} + (Q_{h/4} - Q_{h/2}) / (2^p - 1).

The estimate is only meaningful when the differences keep their sign and shrink (0 < p). A quantity
whose differences grow (p < 0) has no limit under refinement: the raw maximum stress at a sharp
cone rim is a stress singularity, and its "value" grows with every refinement. Such a quantity is
reported as not converging, with its change per refinement; the converging alternatives are the
maximum outside ``output.rim_exclusion_mm`` of every rim (``seqv_outside_rim_pa``) and a filleted
rim (``geometry.cone_fillet_mm``), as MODEL.md offers.

With only two rungs (``run --error-estimate``), a second solve one refinement coarser gives
Q_h - Q_2h, and with an assumed order p the estimate is |Q_h - Q_2h| / (2^p - 1).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from suture_fem.studies.convergence.quantities import REFINEMENT_RATIO

#: Relative change per refinement below which a ladder is called settled instead of extrapolated:
#: every rung is a new unstructured gmsh mesh, which moves global quantities by about this much.
SETTLED_REL = 1e-3
#: Smallest observed order the ladder extrapolates with. Below it the changes shrink by less than a
#: factor 2^0.5 = 1.4 per refinement and the Richardson correction, d / (2^p - 1), would exceed 2.4
#: times the last change: an extrapolation far beyond the data, which is what a maximum drifting
#: into a singular corner looks like. Such a ladder is reported as having no limit in sight.
MIN_ORDER = 0.5


@dataclass
class Estimate:
    """Richardson extrapolation from the last three values of a ladder (sizes h, h/2, h/4)."""

    order: float | None
    limit: float | None
    verdict: str  # "converging", "settled", "diverging", "oscillating", "too few rungs"
    correction: float | None = None  # limit - finest value (settled: the last change, as an uncertainty)

    @property
    def converging(self) -> bool:
        """Whether the ladder has a limit: it converges, or has settled."""
        return self.verdict in ("converging", "settled")


def richardson(values: Sequence[float], ratio: float = REFINEMENT_RATIO, settled_rel: float = 0.0,
               min_order: float = 0.0, tolerance: float = 0.0) -> Estimate:
    """Observed order and extrapolated limit from the last three of ``values`` (coarse to fine).

    When both changes are within ``settled_rel`` of the finest value (the noise floor of a new mesh
    per rung), the ladder is "settled": the finest value is the estimate and the last change its
    uncertainty (no order is measurable). An observed order at or below ``min_order`` is
    "diverging": no extrapolation is made.

    ``tolerance`` is a quantity's own accuracy goal (2 % for the converging stress
    measures). The ladder is also "settled" when the change between its two finest rungs is within
    it and the Richardson estimate agrees: a converging ladder whose correction (extrapolated limit
    minus finest value) is within the tolerance too (limit and correction as extrapolated), or an
    oscillation whose amplitude shrinks (the finest value, the last change its uncertainty) or whose
    two changes are both within the tolerance (the finest value, the larger change its
    uncertainty). Monotone changes within the tolerance that do not shrink are not settled: nothing
    says the drift stops.
    """
    if len(values) < 3:
        return Estimate(None, None, "too few rungs")
    q0, q1, q2 = values[-3:]
    d1, d2 = q1 - q0, q2 - q1
    if max(abs(d1), abs(d2)) <= settled_rel * abs(q2):
        return Estimate(None, q2, "settled", abs(d2))
    within = abs(d2) <= tolerance * abs(q2)
    if d1 * d2 <= 0.0:
        if within and abs(d2) <= abs(d1):
            return Estimate(None, q2, "settled", abs(d2))
        if max(abs(d1), abs(d2)) <= tolerance * abs(q2):  # a bounded wobble within the tolerance
            return Estimate(None, q2, "settled", max(abs(d1), abs(d2)))
        return Estimate(None, None, "oscillating")
    order = math.log(d1 / d2) / math.log(ratio)
    if order <= max(min_order, 0.0):
        return Estimate(order, None, "diverging")
    correction = d2 / (ratio**order - 1.0)
    settled = within and abs(correction) <= tolerance * abs(q2)
    return Estimate(order, q2 + correction, "settled" if settled else "converging", correction)


def two_rung_error(fine: float, coarse: float, order: float = 1.0, ratio: float = REFINEMENT_RATIO) -> float:
    """|Q_h - Q_2h| / (r^p - 1): the error of Q_h for an assumed order p.

    With p = 1, the default, the estimate is the difference itself, which is conservative whenever
    the true order is 1 or more (the ledger shows the observed orders).
    """
    return abs(fine - coarse) / (ratio**order - 1.0)
