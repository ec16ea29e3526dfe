"""SEQV and EPTOEQV averaged over a disc of radius ``output.critical_distance_mm``, maximised over positions.

The theory of critical distances (area method): the stress and strain averaged over a disc of the
r-z section (weighted by 2 pi r) of a named radius, at the position where that average is largest,
over the disc's part in the region (each tissue layer, and the whole tissue). An integral of the
field, it has a limit under refinement even at a sharp cone rim. The averaging is in
:mod:`suture_fem.outputs.disc`; results.json gives the value and the disc's centre (``_at_mm``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suture_fem.geometry.regions import MM, TISSUE_REGIONS
from suture_fem.outputs.base import REPORT_REGIONS, Maximum, Quantity, Setup, State
from suture_fem.outputs.disc import CellField, max_disc_average, top_points
from suture_fem.scene.schema import OutputSection
from suture_fem.support import compat

#: The averaged fields: (results.json name, the ``output.quantities`` option, values at the points of a region).
FIELDS = (
    ("seqv_cd_pa", "seqv", lambda state, region: state.von_mises(region)),
    ("eptoeqv_cd", "eptoeqv", lambda state, region: state.hencky(region)[0]),
)


class CriticalDistance(Quantity):
    """``seqv_cd_pa`` and ``eptoeqv_cd`` of each tissue layer and of the tissue, with their discs' centres."""

    option = None

    @classmethod
    def wanted(cls, quantities: tuple[str, ...]) -> bool:
        """Asked for with SEQV or EPTOEQV (each average with its own field)."""
        return any(option in quantities for _, option, _ in FIELDS)

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where the averages are taken."""
        if output.critical_distance_mm <= 0:
            return {}
        disc = (f"average over a disc of radius {output.critical_distance_mm:g} mm (output.critical_distance_mm) in "
                "the r-z section, weighted by 2 pi r, over the disc's part in the region, at the position where it "
                "is largest (theory of critical distances); _at_mm is the disc's centre; converges under refinement")
        return {"seqv_cd_pa": "von Mises stress " + disc, "eptoeqv_cd": "equivalent Hencky strain " + disc}

    def __init__(self, setup: Setup, radius_mm: float | None = None):
        super().__init__(setup)
        self.radius = (setup.output.critical_distance_mm if radius_mm is None else radius_mm) * MM
        self.fields = [(name, fn) for name, option, fn in FIELDS if option in setup.quantities]
        points = setup.points
        mesh = setup.physics.mesh
        owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.parts: dict[str, Any] = {}
        if self.radius <= 0 or points is None:
            return
        for region in (*TISSUE_REGIONS, "tissue"):
            layers = TISSUE_REGIONS if region == "tissue" else (region,)
            cells = np.concatenate([points.cells[t] for r in layers for t in REPORT_REGIONS[r] if len(points.cells[t])]
                                   or [np.zeros(0, dtype=np.int32)])
            mine = cells < owned
            xy = np.concatenate([points.xy[r] for r in layers]).reshape(len(cells), -1, 2) if len(cells) else None
            self.parts[region] = (layers, cells[mine], mine, None if xy is None else xy[mine],
                                  compat.cell_locator(mesh, cells[mine]))

    def _measure(self, state: State, region: str) -> dict[str, Any]:
        if region not in self.parts:
            return {}
        xy = self.parts[region][3]
        out: dict[str, Any] = {}
        for name, fn in self.fields:
            field, values = self.field(state, region, fn)
            flat_xy = xy.reshape(-1, 2) if xy is not None else np.zeros((0, 2))
            starts = top_points(state.comm, values.reshape(-1), flat_xy, self.radius)
            found = max_disc_average(field, starts, self.radius)
            out[name] = Maximum(found.value, [c / MM for c in found.at] if found.at is not None else None)
        return out

    def field(self, state: State, region: str, fn: Any) -> tuple[CellField, np.ndarray]:
        """A region's field ``fn`` (a function of :data:`FIELDS`) at the state: (the fitted field, its point values)."""
        layers, cells, mine, xy, locate = self.parts[region]
        values = np.concatenate([fn(state, r) for r in layers])
        values = values.reshape(len(mine), -1)[mine] if len(mine) else np.zeros((0, 1))
        xy = xy if xy is not None else np.zeros((0, 1, 2))
        return CellField(self.setup.physics.mesh, cells, xy, values, locate), values

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The largest disc averages of one tissue layer (collective)."""
        return self._measure(state, region) if region in TISSUE_REGIONS else {}

    def in_tissue(self, state: State) -> dict[str, Any]:
        """The largest disc averages over the whole tissue (discs may cross the layers' interfaces)."""
        return self._measure(state, "tissue")
