"""The measured curve a calibration fits: a CSV file of a tensiometer pull, or the paper's own values.

A CSV file has rows ``force_n,displacement_mm[,sd_mm]`` (a header line of words is skipped): the
axial displacement of the thread's pulled end at each force, as in the paper's Fig. 4, optionally
with the measurement's standard deviation. ``--data paper`` takes the paper's USUM values (Table 1 and
section 2.2), each row with its cone count and force. Every value also carries its printed precision
(one unit of its last printed digit), which gives the interval when the data determine the parameters
exactly.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

from suture_fem.studies.paper import PAPER
from suture_fem.support.errors import SceneError

#: The model quantity compared with each kind of data.
THREAD_END = "thread_end_displacement_mm"
USUM = "usum_mm"
#: The tissue's converged stress measures (results.json's ``regions.tissue`` critical-distance averages): predicted
#: with their bands at the fitted parameters, never fitted (no data of them).
SEQV_CD = "seqv_cd_pa"
EPTOEQV_CD = "eptoeqv_cd"
#: Each predicted quantity's unit.
UNITS = {THREAD_END: "mm", USUM: "mm", SEQV_CD: "Pa", EPTOEQV_CD: "1"}


class DataError(SceneError):
    """A data file that cannot be read as a curve (exit code 2, one line naming the row and column)."""


@dataclass(frozen=True)
class Point:
    """One measured value.

    Attributes:
        force_n: the force (N); cones: the cone count of its case (None: the scene's own).
        value_mm: the measured displacement; sd_mm: its standard deviation (None: not given).
        resolution_mm: one unit in the last printed digit of ``value_mm``.
        quantity: the model quantity it is compared with (:data:`THREAD_END` or :data:`USUM`).
        label: where it comes from.
    """

    force_n: float
    value_mm: float
    sd_mm: float | None
    resolution_mm: float
    quantity: str
    cones: int | None = None
    label: str = ""


def resolution(text: str) -> float:
    """One unit in the last printed digit of a number as written ("4.0" -> 0.1, "12" -> 1, "1e-3" -> 1e-3)."""
    mantissa, _, exponent = text.strip().lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def paper_points() -> list[Point]:
    """The paper's USUM values (4 cones at 1-4 N, Table 1; 1-3 cones at 1 N, section 2.2)."""
    return [Point(p.force_n, p.value, None, resolution(p.printed.split()[0]), USUM, p.cones,
                  f"{p.source}, {p.cones} cones, {p.force_n:g} N") for p in PAPER if p.quantity == "usum_mm"]


def _number(text: str, where: str, positive: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"{where}: {text.strip()!r} is not a number") from None
    if not math.isfinite(value) or (positive and value <= 0) or value < 0:
        raise DataError(f"{where}: {text.strip()!r} must be a finite number {'> 0' if positive else '>= 0'}")
    return value


def read_csv(path: str | Path) -> list[Point]:
    """The rows of a CSV curve (DataError, one line naming the row and column, for anything else)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"--data {path}: cannot be read ({exc.__class__.__name__})") from None
    points: list[Point] = []
    names = ("force_n", "displacement_mm", "sd_mm")
    for i, row in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if i == 1 and not _numeric(cells[0]):
            continue  # a header
        if len(cells) not in (2, 3):
            raise DataError(f"--data {path}: row {i}: expected 2 or 3 columns (force_n, displacement_mm[, sd_mm]), "
                            f"got {len(cells)}")
        values = [_number(c, f"--data {path}: row {i}, column {names[j]}", positive=j != 1)
                  for j, c in enumerate(cells)]
        points.append(Point(values[0], values[1], values[2] if len(values) == 3 else None, resolution(cells[1]),
                            THREAD_END, None, f"row {i}"))
    if not points:
        raise DataError(f"--data {path}: no data rows (expected force_n, displacement_mm[, sd_mm])")
    seen: dict[float, str] = {}
    for p in points:
        if p.force_n in seen:
            raise DataError(f"--data {path}: {p.label}, column force_n: {p.force_n:g} N repeats {seen[p.force_n]}")
        seen[p.force_n] = p.label
    if len({p.sd_mm is None for p in points}) > 1:
        raise DataError(f"--data {path}: column sd_mm: given on some rows only (give it on every row or none)")
    return sorted(points, key=lambda p: p.force_n)


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def load(source: str) -> list[Point]:
    """``paper`` or a CSV file."""
    return paper_points() if source == "paper" else read_csv(source)
