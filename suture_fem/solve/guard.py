"""The admissible domain: each material's limits (J > 0, Gent margin > 0) at the quadrature points.

Before a residual is assembled, every quadrature point is checked for J > 0 and, in Gent regions,
I1bar - 3 < Jm (:meth:`DomainGuard.admissible`). A trial state outside that domain is never evaluated
into NaN: the Newton solver (:mod:`suture_fem.solve.newton`) rejects it instead. A converged state is
also checked against the physical limit ``solver.gent_limit_fraction`` (:meth:`DomainGuard.limit_reached`):
Gent's energy only blows up at I1bar - 3 = Jm, so "the limit is reached" means (I1bar - 3) / Jm >= that
fraction somewhere (the load stepping rejects a state there like a failed step).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.regions import REGION_OF_TAG
from suture_fem.physics.forms import quadrature_degree
from suture_fem.physics.materials import Limit, Material
from suture_fem.physics.problem import Physics
from suture_fem.support import compat


@dataclass(frozen=True)
class Violation:
    """The most offending quadrature point of a check (over every rank).

    Attributes:
        region: the material region; quantity: the limit; value: its value there.
        badness: how far outside (or, for the Gent limit, the fraction (I1bar - 3) / Jm used).
        r_mm, z_mm: where (mm).
        limit: for a reached physical limit, the test that failed (text), else None.
    """

    region: str
    quantity: Limit
    value: float
    badness: float
    r_mm: float
    z_mm: float
    limit: str | None = None


class DomainGuard:
    """Evaluates each material's limits (:class:`~suture_fem.physics.materials.Limit`) at the quadrature points.

    The last violation found is kept in ``violation``.
    """

    def __init__(self, mesh: Any, x: Any, F: Any, degree: int, materials: dict[str, Material],
                 cells: Sequence[tuple[str, np.ndarray]]):
        """Compile the checks.

        Args:
            mesh: the mesh (its communicator is the guard's).
            x: the mesh's SpatialCoordinate (to say where a violation is).
            F: the deformation gradient (UFL) of the state's displacement.
            degree: the displacement's degree (the quadrature is that of the residual).
            materials: region -> material.
            cells: (region, local cells) for each part of the mesh to check, in order.
        """
        cell = "tetrahedron" if mesh.geometry.dim == 3 else "triangle"
        points = compat.quadrature_points(cell, quadrature_degree(degree))
        self.mesh, self.comm, self.materials = mesh, mesh.comm, materials
        self.checks: list[tuple[str, Limit, Any, np.ndarray]] = []
        self._x = compat.expression(x, points)
        for region, region_cells in cells:
            for limit, expr in materials[region].limits(F).items():
                self.checks.append((region, limit, compat.expression(expr, points), region_cells))
        self.violation: Violation | None = None
        self.n_points = len(points)
        self.contact: Any = None  # the cones' contact (its ``deepest``), checked after the materials' limits

    @classmethod
    def of(cls, physics: Physics) -> DomainGuard:
        """The guard of a scene's physics: every tagged region, except a rigid suture (which cannot invert)."""
        cells = [(region, meshmod.region_cells(physics.tagged, tag)) for tag, region in REGION_OF_TAG.items()
                 if not (tag in regions.SUTURE and physics.effects.rigid)]
        guard = cls(physics.mesh, physics.x, physics.F, physics.degree, physics.materials, cells)
        guard.contact = getattr(physics, "cone_contact", None)
        return guard

    def margins(self) -> dict[tuple[str, Limit], tuple[float, Any]]:
        """Smallest value of each limit on this rank (with its location), before any reduction."""
        out: dict[tuple[str, Limit], tuple[float, Any]] = {}
        for region, limit, expr, cells in self.checks:
            if len(cells) == 0:
                continue
            vals = compat.eval_expression(expr, self.mesh, cells).reshape(len(cells), -1)
            k = int(np.argmin(vals))
            if (region, limit) not in out or vals.flat[k] < out[(region, limit)][0]:
                out[(region, limit)] = (float(vals.flat[k]), (cells[k // vals.shape[1]], k % vals.shape[1]))
        return out

    def _worst(self, offending: Callable[[str, Limit, float], float | None]) -> Violation | None:
        """The most offending point over all ranks (collective); offending() returns a badness or None."""
        worst: tuple[float, str, Limit, float, Any] | None = None
        for (region, limit), (value, where) in self.margins().items():
            bad = offending(region, limit, value)
            if bad is not None and (worst is None or bad > worst[0]):
                worst = (bad, region, limit, value, where)
        local = None
        if worst is not None:
            bad, region, limit, value, (cell, ip) = worst
            xy = compat.eval_expression(self._x, self.mesh, np.array([cell], dtype=np.int32))
            xy = xy.reshape(-1, self.mesh.geometry.dim)[ip] / regions.MM
            if len(xy) == 3:  # 3-D: (x, y, z) -> (r, axial)
                xy = np.array([np.hypot(xy[0], xy[2]), xy[1]])
            local = Violation(region=region, quantity=limit, value=value, badness=bad,
                              r_mm=float(xy[0]), z_mm=float(xy[1]))
        found = [v for v in self.comm.allgather(local) if v is not None]
        return max(found, key=lambda v: v.badness) if found else None

    def admissible(self) -> bool:
        """True on every rank when the current state is inside the domain everywhere (collective)."""

        def outside(region: str, limit: Limit, value: float) -> float | None:
            if limit is Limit.J and not value > 0.0:
                return math.inf  # an inverted element is the root cause (the other limits are NaN there)
            if not math.isfinite(value):
                return 1e300
            return -value if value <= 0.0 else None

        self.violation = self._worst(outside)
        if self.violation is None and self.contact is not None:  # a tissue node gone through a cone's thin wall
            self.violation = self._too_deep()
        return self.violation is None

    def anchor(self) -> None:
        """The current state is where the next trial states start from (the cones' contact measures their ways)."""
        if self.contact is not None:
            self.contact.anchor()

    def _too_deep(self) -> Violation | None:
        """A tissue node deeper inside a cone than its search allows, the deepest (collective), else None."""
        depth, limit, where, cone = self.contact.deepest()
        if depth <= limit:
            return None
        return Violation(region=f"cone {cone + 1}", quantity=Limit.CONE_DEPTH, value=depth / regions.MM,
                         badness=depth / limit, r_mm=float(where[0]), z_mm=float(where[1]))

    def limit_reached(self, fraction: float) -> Violation | None:
        """Where (I1bar - 3) / Jm >= fraction in a Gent region (collective), else None."""

        def used(region: str, limit: Limit, value: float) -> float | None:
            usage = self.materials[region].usage(limit, value)  # the law's own: (I1bar - 3) / Jm for Gent
            return usage if usage is not None and usage >= fraction else None

        found = self._worst(used)
        if found is None:
            return None
        text = f"(I1bar - 3) / Jm = {found.badness:.4f} >= solver.gent_limit_fraction = {fraction:g}"
        return Violation(**{**found.__dict__, "limit": text})
