"""The paper's values (Mousavi et al., Tables 1 and 2, section 2.2) and the cases ``reproduce`` solves.

A table the studies read (``reproduce`` compares with it, ``calibrate`` fits to it); it imports nothing
from the package, so no study reaches another through it.

One load ramp per cone count (:data:`CONES`: 1, 2, 3, 4 cones to 4 N, reported at :data:`FORCES_N`: 1,
2, 3, 4 N). Every value the paper prints is one :class:`PaperValue`; the Table 1 SEQV at 4 cones, 1 N
(23549 kPa) is kept with the reason it is not used (an evident misprint). :data:`TARGET` is the one
value a dimension may be calibrated against.
"""

from __future__ import annotations

from dataclasses import dataclass

#: The built-in scene ``reproduce`` solves (4 cones, ramp to 4 N, reports at 1, 2, 3 N, converged mesh).
SCENE = "paper_reproduction"
CONES = (1, 2, 3, 4)
FORCES_N = (1.0, 2.0, 3.0, 4.0)
QUANTITIES = ("usum_mm", "seqv_pa", "eptoeqv")
LABELS = {"usum_mm": "USUM (mm)", "seqv_pa": "SEQV (kPa)", "eptoeqv": "EPTOEQV"}


@dataclass(frozen=True)
class PaperValue:
    """One value printed in the paper.

    Attributes:
        source: where it is printed ("Table 1", "Table 2", "Section 2.2").
        cones, force_n: the case.
        quantity: "usum_mm" (mm), "seqv_pa" (Pa) or "eptoeqv".
        value: the value in the unit of ``quantity``.
        printed: the value as printed, with the paper's unit.
        typo: why the value is not used, when it is an evident misprint.
    """

    source: str
    cones: int
    force_n: float
    quantity: str
    value: float
    printed: str
    typo: str | None = None


def _table1() -> list[PaperValue]:
    usum = ("4.0", "5.3", "6.7", "7.6")
    seqv_kpa = ("23549", "587.78", "1100", "2450")
    epto = ("1.24", "1.57", "1.85", "2.03")
    out = []
    for f, u, s, e in zip(FORCES_N, usum, seqv_kpa, epto):
        out.append(PaperValue("Table 1", 4, f, "usum_mm", float(u), f"{u} mm"))
        typo = ("evident misprint: 100 times Table 2's 235490 Pa for the same case, and above the 2 N value"
                if f == 1.0 else None)
        out.append(PaperValue("Table 1", 4, f, "seqv_pa", float(s) * 1e3, f"{s} kPa", typo))
        out.append(PaperValue("Table 1", 4, f, "eptoeqv", float(e), e))
    return out


def _table2() -> list[PaperValue]:
    out = []
    for n, s, e in zip((2, 3, 4), ("662340", "448324", "235490"), ("1.57", "1.42", "1.24")):
        out.append(PaperValue("Table 2", n, 1.0, "seqv_pa", float(s), f"{s} Pa"))
        out.append(PaperValue("Table 2", n, 1.0, "eptoeqv", float(e), e))
    return out


def _section22() -> list[PaperValue]:
    """USUM at 1 N for 1-3 cones (section 2.2 and Figure 3; the 4-cone value is Table 1's)."""
    return [PaperValue("Section 2.2", n, 1.0, "usum_mm", float(u), f"{u} mm")
            for n, u in ((1, "7.3"), (2, "5.1"), (3, "4.4"))]


PAPER: tuple[PaperValue, ...] = tuple(_table1() + _table2() + _section22())
#: The one value a dimension may be calibrated against: USUM, 4 cones, 1 N (Table 1).
TARGET = next(p for p in PAPER if p.source == "Table 1" and p.force_n == 1.0 and p.quantity == "usum_mm")
