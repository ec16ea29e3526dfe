"""``suture-fem holding SCENE``: the pull at which the tissue tears or the thread breaks first, bracketed.

A layer fails where its critical-distance average (``output.critical_distance_mm``; stress or strain by
``strength.criterion``) reaches its strength, the thread where the pull reaches its breaking force
(:mod:`suture_fem.studies.holding.curves`). The scene is meshed once (:class:`suture_fem.Model`) and
solved in passes, each a ramp from rest with reported forces on a grid:

1. the scene's force, then doubled (never past ``--up-to``, nor the thread's breaking force at the
   high end of its band, which no first failure can pass) until a part fails with every strength at the
   high end of its band, or the ramp stops (the Gent limit: the model can go no further);
2. the bracket of the first failure narrowed by ramps to its upper force with reports spaced evenly
   inside it, until it is narrower than ``--tol``: at every strength's low end, at its high end (the
   band's ends: all parts together), and at the strengths' values (the answer).

With a calibration record the band also spans the first failure at both ends of each calibrated
parameter's 95 % interval (a Constant of the forms, set without re-meshing; interpolated on one pass 1
each). Writes holding.json,
holding.md and failure_index.png (:mod:`suture_fem.studies.holding.report`).
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.geometry.section import Geometry
from suture_fem.scene import Scene
from suture_fem.studies.holding.curves import (
    Crossing,
    Sample,
    failure_force,
    first_failure,
    merged,
    sample,
    strengths,
)
from suture_fem.studies.holding.report import failure_index_picture, which_cone, write
from suture_fem.support.errors import SceneError, SolveStopped

log = logging.getLogger("suture_fem")

#: Reported forces per pass (the default of ``grid``).
GRID = 16
#: Forces are never reported closer than this fraction of the pass's top force (the ramp's own floor).
MIN_SPACING = 1e-6


def prepared(scene: Scene) -> Scene:
    """The scene as the holding study solves it: its layers' critical-distance averages computed."""
    if scene.loading.control != "force":
        raise SceneError('holding: loading.control = "displacement" is not supported (the study brackets a '
                         'force); use loading.control = "force"')
    if scene.output.critical_distance_mm <= 0:
        raise SceneError("holding: output.critical_distance_mm must be > 0 (the failure criterion is the "
                         "critical-distance average)")
    quantity = "seqv" if scene.strength.criterion == "stress" else "eptoeqv"
    quantities = sorted(set(scene.output.quantities) | {"usum", quantity})
    return scene.with_values({"output.critical_distance_layers": True, "output.quantities": quantities,
                              "output.fields": False})


class Holding:
    """The passes of one holding study on one built model (collective over its communicator)."""

    def __init__(self, model: Any, up_to_n: float, tol_n: float, grid: int = GRID):
        self.model, self.up_to_n, self.tol_n, self.grid = model, up_to_n, tol_n, grid
        self.samples: list[Sample] = []
        self.passes: list[dict[str, Any]] = []
        self.stop: dict[str, Any] | None = None
        self.thread_end_mm = [0.0, Geometry.from_section(model.scene.geometry).z_end]

    @property
    def scene(self) -> Scene:
        """The model's scene (its force and reports change per pass)."""
        return self.model.scene

    def solve(self, top_n: float, forces: list[float]) -> None:
        """One ramp from rest to ``top_n`` with outputs at ``forces``; its samples kept, a stop recorded."""
        forces = sorted({round(f, 12) for f in forces if 0 < f <= top_n} | {top_n})
        self.model.set({"loading.force_n": top_n, "loading.report_forces_n": forces})
        t0, stopped = time.process_time(), None
        try:
            results = self.model.solve()
        except SolveStopped as stop:
            results, stopped = self.model.results, stop
        new = [sample(r, self.scene.strength.criterion, self.thread_end_mm) for r in results.at_forces]
        self.samples.extend(new)
        self.passes.append({"to_n": top_n, "reports": len(new), "cpu_s": round(time.process_time() - t0, 2),
                            "stopped": stopped.cause if stopped else None})
        if stopped is not None and (self.stop is None or stopped.load_reached < self.stop["force_n"]):
            self.stop = {"cause": stopped.cause, "force_n": stopped.load_reached, "detail": stopped.detail}

    def reach(self, start_n: float) -> None:
        """Pass 1: ramps to start_n, 2 start_n, ... until a part fails with every strength at its band's high end."""
        cap = min(self.up_to_n, strengths(self.scene, "high")["thread"])
        top = min(start_n, cap)
        while True:
            self.solve(top, list(np.linspace(0.0, top, self.grid + 1)[1:]))
            done = first_failure(self.samples, strengths(self.scene, "high")) is not None
            if done or self.stop is not None or top >= cap:
                return
            top = min(2.0 * top, cap)

    def narrow(self, end: str = "value") -> Crossing | None:
        """Pass 2: ramps that close the first failure's bracket to ``tol`` (strengths at ``end`` of their band)."""
        at = strengths(self.scene, end)
        crossing = first_failure(self.samples, at)
        while crossing is not None and crossing.above_n - crossing.below_n > self.tol_n:
            lo, hi = crossing.below_n, crossing.above_n
            if hi - lo <= MIN_SPACING * hi:
                break
            self.solve(hi, list(np.linspace(lo, hi, self.grid + 1)[1:-1]))
            crossing = first_failure(self.samples, at)
        return crossing


def holding(scene: Scene, comm: Any, up_to_n: float | None = None, tol_n: float = 0.01,
            calibration: dict[str, Any] | None = None, out: Path | None = None,
            pictures: bool = True, name: str = "scene", grid: int = GRID, checked: bool = False) -> dict[str, Any]:
    """Bracket the first failure of ``scene``; returns the holding record (and writes it under ``out``).

    ``calibration``: a calibration record (calibration.json); each calibrated key is set to its value,
    and the band also spans its 95 % interval. ``grid``: reported forces per ramp (each costs the
    critical-distance searches; fewer make each pass cheaper and the narrowing take more passes).
    ``checked``: the scene passed :func:`suture_fem.model.check` already (the command line's), not again.
    """
    from suture_fem.model import Model

    scene = prepared(scene)
    up_to = up_to_n if up_to_n is not None else strengths(scene, "high")["thread"]
    if not 0 < tol_n < up_to:
        raise SceneError(f"holding: --tol = {tol_n:g} N must be > 0 and < --up-to = {up_to:g} N")
    calibrated = {k: p["value"] for k, p in (calibration or {}).get("parameters", {}).items()}
    if calibrated:
        scene = scene.with_values(calibrated)
    t0 = time.process_time()
    model = Model(scene, comm, checked=checked and not calibrated)  # calibrated keys may be lengths
    study = Holding(model, up_to, tol_n, grid)
    study.reach(scene.loading.force_n)
    band = [study.narrow(end) for end in ("low", "high")]  # the band's ends bracketed to tol too
    crossing = study.narrow()  # last: its ramp's reports include the failure's, for the picture
    record = summary(scene, study, crossing, band)
    if out is not None:  # the files now, the calibration's band (more ramps) after
        _files(out, record, model, name, pictures)
    if calibrated:
        record["calibration"] = _calibration_band(model, study, calibration, record)
    record["cpu_s"] = round(time.process_time() - t0, 2)
    if out is not None:
        write(out, record, scene, name, model.comm)
    return record


def _files(out: Path, record: dict[str, Any], model: Any, name: str, pictures: bool) -> None:
    """holding.json and holding.md, and the failure index at the first reported force past the failure."""
    write(out, record, model.scene, name, model.comm)
    if not pictures or record["bracket_n"] is None:
        return
    force = record["bracket_n"][1]
    try:
        with model.at(force):
            failure_index_picture(model, record, out / "failure_index.png")
    except KeyError:  # not among the last pass's reports: solve to it once more
        model.set({"loading.force_n": force, "loading.report_forces_n": [force]}).solve()
        failure_index_picture(model, record, out / "failure_index.png")


def _calibration_band(model: Any, study: Holding, calibration: dict[str, Any], record: dict[str, Any]) -> Any:
    """Widen the band by the first failure at each end of each calibrated parameter's 95 % interval."""
    ends = []
    for key, p in calibration["parameters"].items():
        for value in p["ci95"]:
            model.set({key: value})
            other = Holding(model, study.up_to_n, study.tol_n, study.grid)
            other.reach(study.scene.loading.force_n)
            for end in ("low", "value", "high"):
                found = first_failure(other.samples, strengths(model.scene, end))
                ends.append({"key": key, "value": value, "strengths": end,
                             "force_n": found.force_n if found else None})
        model.set({key: p["value"]})
    known = [e["force_n"] for e in ends if e["force_n"] is not None]
    low, high = record["band_n"]
    if known:
        record["band_n"] = [min([low, *known]) if low is not None else min(known),
                            max([high, *known]) if high is not None and len(known) == len(ends) else None]
    return {"parameters": {k: p["value"] for k, p in calibration["parameters"].items()}, "ends": ends}


def summary(scene: Scene, study: Holding, crossing: Crossing | None, band: list[Crossing | None]) -> dict[str, Any]:
    """The holding record: force, bracket, band, mode, layer, cone, where; the samples and the passes."""
    reached = max((s.force_n for s in study.samples), default=0.0)
    record: dict[str, Any] = {
        "force_n": crossing.force_n if crossing else None,
        "bracket_n": [crossing.below_n, crossing.above_n] if crossing else None,
        "band_n": [band[0].force_n if band[0] else None, band[1].force_n if band[1] else None],
        "band_modes": [b.part if b else None for b in band],
        "mode": None if crossing is None else ("thread" if crossing.part == "thread" else "tear"),
        "layer": crossing.part if crossing and crossing.part != "thread" else None,
        "cone": which_cone(scene, crossing.at_mm) if crossing else None,
        "at_mm": crossing.at_mm if crossing else None,
        "criterion": scene.strength.criterion, "tolerance_n": study.tol_n, "up_to_n": study.up_to_n,
        "strengths": {end: strengths(scene, end) for end in ("low", "value", "high")},
        "reached_n": reached, "stop": study.stop, "passes": study.passes,
        "samples": [{"force_n": s.force_n, **s.values} for s in merged(study.samples)],
        "parts_n": {part: (c.force_n if (c := failure_force(study.samples, part, value)) else None)
                    for part, value in strengths(scene).items()},
    }
    if crossing is None:
        record["note"] = (f"no part reached its strength up to {reached:.4g} N"
                          + (f": the ramp stopped there ({study.stop['cause']})" if study.stop else ""))
    return record
