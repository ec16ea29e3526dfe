"""The mesh rung of each cone count: the cheapest one whose USUM is within 1 % of the mesh-converged value.

Chosen from measured ladders (``benchmarks/reproduce_rungs.py``: ``suture-fem convergence
paper_reproduction --set geometry.cones=N --degrees 1,2 --refinements 0,1,2 --cap 2=1 --forces
1,2,3,4`` for N = 1-4, the 1-cone P1 ladder with ``mesh.size_suture_mm = 0.1``, and the single 1-cone
P1 r0 rung with ``mesh.size_suture_mm = 0.075`` that is chosen; the tables are in docs/speed.md).
Each rung records its estimated relative discretisation error of USUM at every reported force:
(USUM at the rung - reference) / reference, where the reference is the Richardson limit
of the P1 ladder r0-r2 (refinement ratio 2, observed order) when that ladder converges monotonically at
that force, else the finest rung solved (P2 r1); :data:`ESTIMATE` says so for each rung.

The estimates are measured on the uncalibrated scene (``materials.tissue_scale`` = 1). ``reproduce``
attaches them to its values only when the case's mesh is the rung's (a ``--set mesh.*`` of the user
replaces the rung's key and the estimate is then not shown).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Rung:
    """The mesh of one cone count and USUM's estimated relative error on it.

    Attributes:
        label: short name, e.g. ``P1 r0`` or ``P1 r0, suture 0.1 mm``.
        values: the scene's mesh keys of the rung (dotted).
        usum_error: force (N) -> estimated relative error of USUM at this rung (signed: negative when
            the rung's USUM is below the converged one).
        estimate: how the error was estimated.
        usum_reference_mm: force (N) -> the mesh-converged USUM (mm) the error is measured against.
        cpu_s: CPU seconds of the rung's ramp in the ladder (how ``--jobs`` balances its processes).
    """

    label: str
    values: dict[str, Any]
    usum_error: dict[float, float] = field(default_factory=dict)
    estimate: str = ""
    usum_reference_mm: dict[float, float] = field(default_factory=dict)
    cpu_s: float = 0.0


_P2R0 = ("against the P2 r0 rung (at 1 and 4 cones P2 r0 is 0.1-0.2 % below the converged value, so the error "
         "may be that much larger)")
#: Measured (Debian 12, dolfinx 0.5.2, gmsh 4.8, sharp rims) with benchmarks/reproduce_rungs.py;
#: the table is in docs/speed.md. ``cpu_s``: the rung's process in the ladder (imports included, a shared machine).
RUNGS: dict[int, Rung] = {
    1: Rung("P1 r0, suture 0.075 mm", {"mesh.degree": 1, "mesh.refinement": 0, "mesh.size_suture_mm": 0.075},
            usum_error={1.0: -0.00514, 2.0: -0.00648, 3.0: -0.00624, 4.0: -0.00700},
            estimate="against the Richardson limit of the P1 r0-r2 ladder (observed order 1.00, 0.93) at 1 and 2 N, "
                     "the P2 r1 rung at 3 and 4 N (the P1 r2 ramp stopped at 2.78 N); the reference's uncertainty "
                     "about 0.1 %",
            usum_reference_mm={1.0: 4.13856, 2.0: 5.50964, 3.0: 6.53310, 4.0: 7.39643}, cpu_s=11.1),
    2: Rung("P1 r0", {"mesh.degree": 1, "mesh.refinement": 0, "mesh.size_suture_mm": 0.15},
            usum_error={1.0: -0.00540, 2.0: -0.00645, 3.0: -0.00739, 4.0: -0.00812}, estimate=_P2R0,
            usum_reference_mm={1.0: 3.25689, 2.0: 4.32278, 3.0: 5.11168, 4.0: 5.76682}, cpu_s=8.0),
    3: Rung("P1 r0", {"mesh.degree": 1, "mesh.refinement": 0, "mesh.size_suture_mm": 0.15},
            usum_error={1.0: -0.00496, 2.0: -0.00556, 3.0: -0.00627, 4.0: -0.00690}, estimate=_P2R0,
            usum_reference_mm={1.0: 2.83599, 2.0: 3.79071, 3.0: 4.49694, 4.0: 5.08438}, cpu_s=9.2),
    4: Rung("P1 r0", {"mesh.degree": 1, "mesh.refinement": 0, "mesh.size_suture_mm": 0.15},
            usum_error={1.0: -0.00580, 2.0: -0.00629, 3.0: -0.00679, 4.0: -0.00717},
            estimate="against the Richardson limit of the P1 r0-r2 ladder (observed order 1.02-1.08); the "
                     "reference's uncertainty about 0.1 % (P2 r0 differs from it by that)",
            usum_reference_mm={1.0: 2.57751, 2.0: 3.47572, 3.0: 4.14263, 4.0: 4.69834}, cpu_s=10.7),
}


def rung_values(rung: Rung | None, fixed: frozenset[str] | set[str] = frozenset()) -> dict[str, Any]:
    """The rung's scene keys but those the user set (``fixed``: dotted keys given with ``--set``)."""
    return {} if rung is None else {k: v for k, v in rung.values.items() if k not in fixed}

