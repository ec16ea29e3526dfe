"""The outputs at one reported force, typed: :class:`Report` reads a results.json ``at_forces`` entry.

A Report is a read-only view of the record the outputs evaluated (the same dict results.json writes),
with the paper's answers as attributes (``report.usum_mm``, ``report.seqv_pa``, ``report.eptoeqv``)
and every maximum with where it is (:meth:`Report.peak`: a :class:`Peak` with the value, the position
r, z in mm and the region). It also reads like the dict (``report["regions"]``).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Peak:
    """A maximum and where it is: ``value`` (in the measure's unit), ``at_mm`` (r, z) and ``region``."""

    value: float
    at_mm: tuple[float, float] | None
    region: str | None


def peak_of(record: Mapping[str, Any], measure: str, region: str | None = None) -> Peak:
    """The Peak of ``measure`` (a key such as ``seqv_pa``, ``eptoeqv_cd``) in a record, or in one of its regions.

    Raises KeyError when the record has no such measure (e.g. SEQV not among ``output.quantities``).
    """
    values = record["regions"][region] if region is not None else record
    at = values.get(f"{measure}_at_mm")
    where = region if region is not None else values.get(f"{measure}_region")
    return Peak(float(values[measure]), tuple(at) if at is not None else None, where)


@dataclass(frozen=True, eq=False)
class Report(Mapping):
    """The outputs at one reported force (one entry of results.json's ``at_forces``), read-only."""

    record: Mapping[str, Any]

    @property
    def force_n(self) -> float:
        """The reported force (N)."""
        return float(self.record["force_n"])

    @property
    def usum_mm(self) -> float:
        """USUM: the largest displacement magnitude over the model (mm)."""
        return float(self.record["usum_mm"])

    @property
    def seqv_pa(self) -> float:
        """SEQV: the largest von Mises stress over the model (Pa; the thread's, see ``regions``)."""
        return float(self.record["seqv_pa"])

    @property
    def eptoeqv(self) -> float:
        """EPTOEQV: the largest equivalent Hencky strain over the model."""
        return float(self.record["eptoeqv"])

    @property
    def thread_end_displacement_mm(self) -> float:
        """The pulled end face's axial displacement (mm)."""
        return float(self.record["thread_end_displacement_mm"])

    @property
    def regions(self) -> Mapping[str, Mapping[str, Any]]:
        """Per region (``hypodermis``, ``dermis``, ``epidermis``, ``suture``, ``tissue``): its measures."""
        return self.record.get("regions", {})

    def peak(self, measure: str, region: str | None = None) -> Peak:
        """The maximum of ``measure`` (``usum_mm``, ``seqv_pa``, ``eptoeqv``, ``seqv_cd_pa``, ...) and where it is."""
        return peak_of(self.record, measure, region)

    def __getitem__(self, key: str) -> Any:
        """The record's entry."""
        return self.record[key]

    def __iter__(self) -> Iterator[str]:
        """The record's keys."""
        return iter(self.record)

    def __len__(self) -> int:
        """The record's number of keys."""
        return len(self.record)
