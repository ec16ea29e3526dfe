"""What the ledger follows through its ladder: the quantities, and how a rung names its forces.

The raw maximum stress at a sharp cone rim is a stress singularity: its "value" grows with every
refinement. Next to it the ledger follows maxima that have a limit: the maximum outside
``output.rim_exclusion_mm`` of every rim (``seqv_outside_rim_pa``), and the tissue's maxima farther
than each of :data:`SINGULAR_FREE_MM` from every singular point (see
:mod:`suture_fem.studies.convergence.singular`), and the two measures that converge by construction:
the peak on the resolved fillet (``seqv_fillet_pa``) and the critical-distance average
(``seqv_cd_pa``, and ``seqv_cd_cone_pa`` with the disc near a cone), with their strains.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

#: Ratio of element sizes between consecutive refinements (mesh.MeshSizes halves every size).
REFINEMENT_RATIO = 2.0

#: Accuracy goal of the two stress measures that converge by construction: a ladder of one
#: of them is "settled" when it changes by less than this per refinement at its two finest rungs and
#: its Richardson estimate agrees (:func:`~suture_fem.studies.convergence.richardson.richardson`).
#: The other quantities keep the noise floor of a new mesh per rung (``SETTLED_REL``, 0.1 %) as their
#: only "settled": USUM reaches it; a local stress measure, whose error falls like h^p with p about
#: 1-2 near a rounded or re-entrant corner, would need several more refinements for it, and 2 % is
#: well inside what the paper's question needs (its 2-to-4-cone falls are 60 % and 20 %).
STRESS_TOLERANCE = 0.02

#: Distances (mm) from every singular point beyond which a ledger rung also takes the tissue's maxima.
SINGULAR_FREE_MM = (0.25, 0.5)


@dataclass(frozen=True)
class Quantity:
    """An output followed through the ladder: dotted path in an ``at_forces`` record of results.json."""

    path: str
    label: str
    unit: str
    tolerance: float = 0.0  # the quantity's own "settled" goal (relative change per refinement), 0: none

    def of(self, record: dict[str, Any]) -> float | None:
        """The quantity's value in an ``at_forces`` record, None where the record has none."""
        value = _lookup(record, self.path)
        return float(value) if isinstance(value, (int, float)) else None

    def where(self, record: dict[str, Any]) -> tuple[float, float] | None:
        """(r, z) in mm where the maximum is taken (results.json's ``<name>_at_mm``)."""
        at = _lookup(record, self.path + "_at_mm")
        return (float(at[0]), float(at[1])) if isinstance(at, list) and len(at) == 2 else None


def _lookup(record: dict[str, Any], dotted: str) -> Any:
    """The value at a dotted path, None where the path does not exist."""
    try:
        node: Any = record
        for part in dotted.split("."):
            node = node[part]
        return node
    except (KeyError, TypeError):
        return None


def beyond(mm: float) -> str:
    """The key suffix of a distance from the singular points: 0.25 -> ``0p25mm``."""
    return f"{mm:g}".replace(".", "p") + "mm"


def fmt_value(v: float | None, unit: str) -> str:
    """A value in its unit for the ledger's tables and verdicts: stresses in kPa or MPa, ``-`` for none."""
    if v is None:
        return "-"
    if unit == "Pa":
        return f"{v / 1e3:.4g} kPa" if abs(v) < 1e6 else f"{v / 1e6:.4g} MPa"
    return f"{v:.4g}" + (f" {unit}" if unit not in ("-", "") else "")


def force_key(force: float) -> str:
    """The key of a force (N) in a rung's values and in the analysis: 1.0 -> ``"1"``."""
    return f"{force:g}"


QUANTITIES = (
    Quantity("usum_mm", "USUM", "mm"),
    Quantity("seqv_pa", "SEQV (overall max, in the suture)", "Pa"),
    Quantity("eptoeqv", "EPTOEQV (overall max)", "-"),
    Quantity("regions.tissue.seqv_pa", "SEQV tissue (raw max; mesh-dependent at a sharp corner)", "Pa"),
    Quantity("regions.tissue.seqv_fillet_pa", "SEQV tissue, peak on the resolved fillet", "Pa", STRESS_TOLERANCE),
    Quantity("regions.tissue.eptoeqv_fillet", "EPTOEQV tissue, peak on the resolved fillet", "-", STRESS_TOLERANCE),
    Quantity("regions.tissue.seqv_cd_pa", "SEQV tissue, critical-distance average", "Pa", STRESS_TOLERANCE),
    Quantity("regions.tissue.eptoeqv_cd", "EPTOEQV tissue, critical-distance average", "-", STRESS_TOLERANCE),
    Quantity("regions.tissue.seqv_cd_cone_pa", "SEQV tissue, critical-distance average near a cone", "Pa",
             STRESS_TOLERANCE),
    Quantity("regions.tissue.eptoeqv_cd_cone", "EPTOEQV tissue, critical-distance average near a cone", "-",
             STRESS_TOLERANCE),
    Quantity("regions.tissue.seqv_outside_rim_pa", "SEQV tissue outside rims", "Pa"),
    Quantity("regions.tissue.eptoeqv_outside_rim", "EPTOEQV tissue outside rims", "-"),
    *(Quantity(f"ledger.tissue_seqv_pa_beyond_{beyond(d)}", f"SEQV tissue > {d:g} mm from singular points", "Pa")
      for d in SINGULAR_FREE_MM),
    *(Quantity(f"ledger.tissue_eptoeqv_beyond_{beyond(d)}", f"EPTOEQV tissue > {d:g} mm from singular points", "-")
      for d in SINGULAR_FREE_MM),
)
