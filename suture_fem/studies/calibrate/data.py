"""The measured curve a calibration fits: a CSV file of a tensiometer pull, or the paper's own values.

A CSV file has rows ``force_n,displacement_mm[,sd_mm]`` (a header line names the columns): the
axial displacement of the thread's pulled end at each force, as in the paper's Fig. 4, optionally
with the measurement's standard deviation. ``--data paper`` takes the paper's USUM values (Table 1 and
section 2.2), each row with its cone count and force. Every value also carries its printed precision
(one unit of its last printed digit), which gives the interval when the data determine the parameters
exactly.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from suture_fem.scene.load import read_text_file
from suture_fem.studies.paper import PAPER
from suture_fem.support.errors import SceneError, shown

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


#: The columns of a CSV curve, in their order when there is no header.
COLUMNS = ("force_n", "displacement_mm", "sd_mm")
#: Most data rows a curve may have: each row is a force the model is solved to at every evaluation of the
#: fit (a tensiometer's thousands of samples would run for days; thin the curve first).
MAX_ROWS = 200


def read_csv(path: str | Path) -> list[Point]:
    """The rows of a CSV curve (DataError, one line naming the row and column, for anything else).

    A header line names the columns (force_n, displacement_mm and optionally sd_mm, in any order); without
    one they are taken in that order. A UTF-8 byte-order mark (a spreadsheet's export) is skipped.
    """
    path = Path(path)
    text = read_text_file(path, f"--data {path}", DataError).removeprefix("\ufeff")
    points: list[Point] = []
    columns: tuple[str, ...] | None = None
    for i, cells in _rows(text, path):
        if columns is None and not _numeric(cells[0]):
            columns = _header(cells, path, i)
            continue
        order = columns or COLUMNS[:len(cells)]
        if len(cells) != len(order) or len(cells) not in (2, 3):
            raise DataError(f"--data {path}: row {i}: expected {len(order) if columns else '2 or 3'} columns "
                            f"({', '.join(columns or COLUMNS)}), got {len(cells)}")
        values = {name: _number(c, f"--data {path}: row {i}, column {name}", positive=name != "displacement_mm")
                  for name, c in zip(order, cells)}
        points.append(Point(values["force_n"], values["displacement_mm"], values.get("sd_mm"),
                            resolution(cells[order.index("displacement_mm")]), THREAD_END, None, f"row {i}"))
        columns = columns or ()  # a header comes first or not at all
        if len(points) > MAX_ROWS:
            raise DataError(f"--data {path}: more than {MAX_ROWS} data rows; each row is a force solved at every "
                            f"evaluation of the fit: thin the curve to at most {MAX_ROWS} rows")
    _check_points(points, path)
    return sorted(points, key=lambda p: p.force_n)


def _rows(text: str, path: Path) -> Iterator[tuple[int, list[str]]]:
    """(line number, stripped cells) of each row that is not empty or a # comment."""
    reader = csv.reader(text.splitlines())
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:  # e.g. a cell over the csv module's 128 KB limit
            raise DataError(f"--data {path}: row {reader.line_num}: {exc}") from None
        cells = [c.strip() for c in row]
        if any(cells) and not cells[0].startswith("#"):
            yield reader.line_num, cells


def _header(cells: list[str], path: Path, i: int) -> tuple[str, ...]:
    names = tuple(c.lower() for c in cells)
    unknown = [shown(c) for c, n in zip(cells, names) if n not in COLUMNS]
    if unknown or len(set(names)) != len(names) or not {"force_n", "displacement_mm"} <= set(names):
        raise DataError(f"--data {path}: row {i}: header {', '.join(shown(c) for c in cells)}: expected the columns "
                        "force_n, displacement_mm and optionally sd_mm (each once, any order)")
    return names


def _check_points(points: list[Point], path: Path) -> None:
    if not points:
        raise DataError(f"--data {path}: no data rows (expected force_n, displacement_mm[, sd_mm])")
    seen: dict[float, str] = {}
    for p in points:
        if p.force_n in seen:
            raise DataError(f"--data {path}: {p.label}, column force_n: {p.force_n:g} N repeats {seen[p.force_n]}")
        seen[p.force_n] = p.label
    if len({p.sd_mm is None for p in points}) > 1:
        raise DataError(f"--data {path}: column sd_mm: given on some rows only (give it on every row or none)")


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def load(source: str) -> list[Point]:
    """``paper`` or a CSV file."""
    return paper_points() if source == "paper" else read_csv(source)
