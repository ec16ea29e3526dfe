"""Outputs: the paper's USUM, SEQV and EPTOEQV, overall and per region, and the balance checks.

Each quantity is one small class in its own module (usum, seqv, eptoeqv, jacobian, reaction,
energy, thread_end), built once per run from the shared :class:`~suture_fem.outputs.base.Setup`;
:class:`Outputs` evaluates the ones a scene asks for into one record per reported force. Adding a
quantity means adding its module and its class to :data:`QUANTITIES`.

The record holds every whole-body value, then, for every maximum, the largest over the regions
(``<name>``, ``<name>_at_mm``, ``<name>_region``), then ``regions`` (each region's values, and
``tissue``: the largest over the tissue layers) and ``where`` (how each maximum is taken).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suture_fem.geometry.regions import TISSUE_REGIONS, WHOLE_TISSUE
from suture_fem.outputs.base import REPORT_REGIONS, Maximum, Quantity, Setup, State
from suture_fem.outputs.cone_gaps import maxima_near_cut_corners
from suture_fem.outputs.critical_distance import CriticalDistance
from suture_fem.outputs.dimple import Dimple
from suture_fem.outputs.energy import StrainEnergy
from suture_fem.outputs.eptoeqv import Eptoeqv
from suture_fem.outputs.fields import cell_maxima
from suture_fem.outputs.fillet_peak import FilletPeak
from suture_fem.outputs.interface import Interface
from suture_fem.outputs.jacobian import JRange
from suture_fem.outputs.reaction import Reaction
from suture_fem.outputs.seqv import Seqv
from suture_fem.outputs.thread_end import ThreadEnd
from suture_fem.outputs.usum import Usum
from suture_fem.physics.problem import Physics
from suture_fem.scene.schema import OutputSection
from suture_fem.support import compat

#: Every quantity, in the order of the record; a scene's ``output.quantities`` selects the optional ones.
QUANTITIES: tuple[type[Quantity], ...] = (ThreadEnd, StrainEnergy, Reaction, Usum, Seqv, Eptoeqv, FilletPeak,
                                          CriticalDistance, JRange, Interface, Dimple)

#: (value, location in mm, region) of the largest maximum found so far.
Best = tuple[float, Any, str]


class Outputs:
    """Builds the requested quantities once, then evaluates them for the current state."""

    def __init__(self, physics: Physics, output: OutputSection,
                 quantities: tuple[str, ...] = (Usum.option, Seqv.option, Eptoeqv.option)):
        self.physics = physics
        self.quantities = quantities
        self.setup = Setup(physics, output, quantities)
        self.active = [cls(self.setup) for cls in QUANTITIES if cls.wanted(quantities)]
        self.thread_end = ThreadEnd(self.setup)
        self.where = {name: text for cls in QUANTITIES if cls.wanted(quantities) or not cls.slab_only
                      for name, text in cls.describe(output).items()}
        if physics.mesh.geometry.dim == 3:  # the critical distance's ball, not the disc
            self.where.update(CriticalDistance.describe(output, dimension=3))

    @property
    def tensor_exprs(self) -> dict[int, Any]:
        """The compiled stress and strain expression per cell tag; empty when neither SEQV nor EPTOEQV is asked for."""
        return self.setup.points.tensor_exprs if self.setup.points is not None else {}

    def thread_end_displacement_mm(self) -> float:
        """Axial displacement of the pulled end face (2 pi r-weighted mean), mm (collective)."""
        return self.thread_end.value()

    def cell_maxima(self) -> dict[str, np.ndarray]:
        """The maximum stress and strain in every local cell, for field files and pictures.

        Per local cell (ghosts included), the maximum over its quadrature points of the von Mises
        stress (Pa, key "von_mises_pa") and of the equivalent Hencky strain ("eptoeqv"), indexed by
        local cell number (needs SEQV or EPTOEQV asked for).
        """
        return cell_maxima(self.setup.points)

    def evaluate(self) -> dict[str, Any]:
        """Every requested output for the current state, JSON-ready (collective)."""
        state = State(self.setup)
        out: dict[str, Any] = {"force_n": state.force_n}
        for quantity in self.active:
            out.update(quantity.totals(state))
        regions, overall = self._regions(state)
        for name, (value, where, region) in overall.items():
            out[name] = value
            out[name + "_at_mm"] = where
            out[name + "_region"] = region
        regions[WHOLE_TISSUE] = _tissue(regions, overall)
        for quantity in self.active:  # whole-tissue maxima that are not the largest layer's
            for name, entry in quantity.in_tissue(state).items():
                regions[WHOLE_TISSUE][name], regions[WHOLE_TISSUE][name + "_at_mm"] = entry
                regions[WHOLE_TISSUE][name + "_region"] = WHOLE_TISSUE
                out[name], out[name + "_at_mm"], out[name + "_region"] = entry.value, entry.at_mm, WHOLE_TISSUE
        out["regions"] = regions
        out["where"] = dict(self.where)
        contact = getattr(self.physics, "cone_contact", None)
        if contact is not None and contact.corners is not None and "cone_contact" in out.get("interface", {}):
            out["interface"]["cone_contact"]["maxima_near_cut_corners"] = maxima_near_cut_corners(
                out, contact, compat.function_vector(self.physics.state), self.setup.output.critical_distance_mm)
        return out

    def _regions(self, state: State) -> tuple[dict[str, Any], dict[str, Best]]:
        """Each region's entries, and the largest of every maximum over the regions."""
        regions: dict[str, Any] = {}
        overall: dict[str, Best] = {}
        for region in REPORT_REGIONS:
            regions[region] = {}
            for quantity in self.active:
                for name, entry in quantity.in_region(state, region).items():
                    if not isinstance(entry, Maximum):
                        regions[region][name] = entry
                        continue
                    regions[region][name], regions[region][name + "_at_mm"] = entry
                    if entry.value > overall.get(name, (-np.inf, None, ""))[0]:
                        overall[name] = (entry.value, entry.at_mm, region)
        return regions, overall


def _tissue(regions: dict[str, Any], overall: dict[str, Best]) -> dict[str, Any]:
    """The largest of every maximum over the tissue layers (None where no tissue layer has one)."""
    tissue: dict[str, Any] = {}
    for name in overall:
        found = [(regions[r][name], regions[r][name + "_at_mm"], r) for r in TISSUE_REGIONS
                 if regions[r].get(name + "_at_mm") is not None]
        tissue[name], tissue[name + "_at_mm"], tissue[name + "_region"] = max(found) if found else (None, None, None)
    return tissue
