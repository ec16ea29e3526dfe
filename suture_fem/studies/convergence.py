"""The accuracy-cost ledger: ``suture-fem convergence SCENE [--set KEY=VALUE ...] [--out DIR]``.

A ladder of solves of one scene, refinement by refinement (every element size halves per step) for
each element degree (and each incompressibility formulation, where the scene has that choice), and
for every rung: wall time, degrees of freedom, Newton iterations, peak memory and the outputs.

Error estimates (Richardson extrapolation with the observed order). For a quantity Q computed on a
ladder of meshes with sizes h, h/2, h/4, if Q_h = Q + C h^p + ..., the last three rungs give

    p = log2((Q_{h/2} - Q_h) / (Q_{h/4} - Q_{h/2})),   Q ~ Q_{h/4} + (Q_{h/4} - Q_{h/2}) / (2^p - 1).

The estimate is only meaningful when the differences keep their sign and shrink (0 < p). A quantity
whose differences grow (p < 0) has no limit under refinement: the raw maximum stress at a sharp
cone rim is a stress singularity, and its "value" grows with every refinement. Such a quantity is
reported as not converging, with its change per refinement; the converging alternatives are the
maximum outside ``output.rim_exclusion_mm`` of every rim (``seqv_outside_rim_pa``) and a filleted
rim (``geometry.cone_fillet_mm``), as MODEL.md offers.

The reference value of a quantity is the extrapolated value of the ladder (degree, formulation)
whose Richardson correction is smallest; every rung's error is its distance to that reference.

Each rung runs by default as its own ``suture-fem run`` process, so its peak memory
(``ru_maxrss`` of that child, from ``os.wait4``) is its own and no rung profits from forms compiled
by another in memory (compiled forms are still shared through the disk cache, as in any run).
Under mpirun, or with ``--inprocess``, the rungs run in this process on its communicator; the peak
memory is then the process's peak so far (summed over ranks) and says so.

``suture-fem run --error-estimate`` uses :func:`attach_error_estimate`: a second solve one
refinement coarser gives Q_h - Q_2h, and with an assumed order p the estimate is
|Q_h - Q_2h| / (2^p - 1). With p = 1, the default, the estimate is the difference itself, which is
conservative whenever the true order is 1 or more (the ledger shows the observed orders).

Outputs in DIR: ``ledger.json``, ``ledger.md`` (tables), ``ledger.png`` (relative error against
wall time, log-log, one curve per quantity and degree; ``ledger-cpu.png`` the same against CPU time,
which a busy machine does not inflate) and ``rungs/<name>/`` (each rung's
results.json, run.log and rung.json). Rungs whose folder already holds a converged result of the
same resolved scene are reused (``--redo`` solves them again).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import resource
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.scene import Scene
from suture_fem.scene.schema import RULES
from suture_fem.support.errors import SceneError
from suture_fem.support.io import read_json, write_json, write_text
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")

#: Ratio of element sizes between consecutive refinements (mesh.MeshSizes halves every size).
REFINEMENT_RATIO = 2.0
#: Relative change per refinement below which a ladder is called settled instead of extrapolated:
#: every rung is a new unstructured gmsh mesh, which moves global quantities by about this much.
SETTLED_REL = 1e-3
#: Smallest observed order the ladder extrapolates with. Below it the changes shrink by less than a
#: factor 2^0.5 = 1.4 per refinement and the Richardson correction, d / (2^p - 1), would exceed 2.4
#: times the last change: an extrapolation far beyond the data, which is what a maximum drifting
#: into a singular corner looks like. Such a ladder is reported as having no limit in sight.
MIN_ORDER = 0.5
#: Version of what a rung records; a rung folder written by another version is solved again.
RUNG_VERSION = 3
#: Scene key of the incompressibility formulation, where the scene has one.
FORMULATION_KEY = "effects.incompressibility"


@dataclass(frozen=True)
class Quantity:
    """An output followed through the ladder: dotted path in an ``at_forces`` record of results.json."""

    path: str
    label: str
    unit: str

    def of(self, record: dict[str, Any]) -> float | None:
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


#: Distances (mm) from every singular point beyond which a ledger rung also takes the tissue's maxima.
SINGULAR_FREE_MM = (0.25, 0.5)


def _beyond(mm: float) -> str:
    return f"{mm:g}".replace(".", "p") + "mm"


QUANTITIES = (
    Quantity("usum_mm", "USUM", "mm"),
    Quantity("seqv_pa", "SEQV (overall max, in the suture)", "Pa"),
    Quantity("eptoeqv", "EPTOEQV (overall max)", "-"),
    Quantity("regions.tissue.seqv_pa", "SEQV tissue (raw max)", "Pa"),
    Quantity("regions.tissue.seqv_outside_rim_pa", "SEQV tissue outside rims", "Pa"),
    Quantity("regions.tissue.eptoeqv_outside_rim", "EPTOEQV tissue outside rims", "-"),
    *(Quantity(f"ledger.tissue_seqv_pa_beyond_{_beyond(d)}", f"SEQV tissue > {d:g} mm from singular points", "Pa")
      for d in SINGULAR_FREE_MM),
    *(Quantity(f"ledger.tissue_eptoeqv_beyond_{_beyond(d)}", f"EPTOEQV tissue > {d:g} mm from singular points", "-")
      for d in SINGULAR_FREE_MM),
)


# ------------------------------------------------------------------------------------ Richardson


@dataclass
class Estimate:
    """Richardson extrapolation from the last three values of a ladder (sizes h, h/2, h/4)."""

    order: float | None
    limit: float | None
    verdict: str  # "converging", "settled", "diverging", "oscillating", "too few rungs"
    correction: float | None = None  # limit - finest value (settled: the last change, as an uncertainty)

    @property
    def converging(self) -> bool:
        return self.verdict in ("converging", "settled")


def richardson(values: Sequence[float], ratio: float = REFINEMENT_RATIO, settled_rel: float = 0.0,
               min_order: float = 0.0) -> Estimate:
    """Observed order and extrapolated limit from the last three of ``values`` (coarse to fine).

    When both changes are within ``settled_rel`` of the finest value, the ladder is "settled": the
    finest value is the estimate and the last change its uncertainty (no order is measurable). An
    observed order at or below ``min_order`` is "diverging": no extrapolation is made.
    """
    if len(values) < 3:
        return Estimate(None, None, "too few rungs")
    q0, q1, q2 = values[-3:]
    d1, d2 = q1 - q0, q2 - q1
    if max(abs(d1), abs(d2)) <= settled_rel * abs(q2):
        return Estimate(None, q2, "settled", abs(d2))
    if d1 * d2 <= 0.0:
        return Estimate(None, None, "oscillating")
    order = math.log(d1 / d2) / math.log(ratio)
    if order <= max(min_order, 0.0):
        return Estimate(order, None, "diverging")
    correction = d2 / (ratio**order - 1.0)
    return Estimate(order, q2 + correction, "converging", correction)


def two_rung_error(fine: float, coarse: float, order: float = 1.0, ratio: float = REFINEMENT_RATIO) -> float:
    """|Q_h - Q_2h| / (r^p - 1): the error of Q_h for an assumed order p."""
    return abs(fine - coarse) / (ratio**order - 1.0)


# ------------------------------------------------------------------------------------------ rungs


@dataclass
class Rung:
    """One solve of the ladder and what it cost."""

    name: str
    degree: int
    refinement: int
    formulation: str | None
    overrides: list[str]
    level_name: str = "r"  # "r": mesh.refinement; "rim": halvings of mesh.size_rim_mm
    status: str = "not run"
    exit_code: int | None = None
    wall_time_s: float | None = None  # inside run_scene: meshing, forms, load ramp, outputs
    process_time_s: float | None = None  # the whole `suture-fem run` process (imports included)
    cpu_time_s: float | None = None  # user + system CPU of the rung (less sensitive to a shared machine)
    compile_time_s: float | None = None  # form compilation inside the rung (near 0 when the disk cache has the forms)
    peak_memory_mb: float | None = None
    memory_note: str = ""
    load_average: list[float] | None = None  # 1-minute load average before and after (a shared machine slows wall time)
    version: int = RUNG_VERSION
    dofs: int | None = None
    cells: int | None = None
    newton_iterations: int | None = None
    load_steps: int | None = None
    values: dict[str, dict[str, float | None]] = field(default_factory=dict)  # force -> quantity path -> value

    @property
    def label(self) -> str:
        form = f" {self.formulation}" if self.formulation else ""
        return f"P{self.degree}{form} {self.level_name}{self.refinement}"


def _force_key(force: float) -> str:
    return f"{force:g}"


def _collect(rung: Rung, results: dict[str, Any]) -> None:
    """The rung's cost and its outputs at every reported force."""
    rung.status = results.get("status", "unknown")
    rung.wall_time_s = results.get("wall_time_s")
    rung.compile_time_s = results.get("timings_s", {}).get("form_compilation")
    rung.dofs = results.get("dofs")
    rung.cells = results.get("cells")
    rung.newton_iterations = results.get("newton_iterations")
    rung.load_steps = results.get("load_steps")
    for rec in results.get("at_forces", []):
        rung.values[_force_key(rec["force_n"])] = {q.path: q.of(rec) for q in QUANTITIES}


def _sets(overrides: Sequence[str]) -> list[str]:
    return [a for o in overrides for a in ("--set", o)]


def _run_subprocess(source: str, rung: Rung, folder: Path) -> dict[str, Any] | None:
    """`suture-fem run` in a child process; its own peak memory from os.wait4."""
    cmd = [sys.executable, "-m", "suture_fem.cli", "ledger-rung", source, *_sets(rung.overrides), "--out", str(folder)]
    t0 = time.perf_counter()
    with open(folder / "run.log", "w") as logfile:
        proc = subprocess.Popen(cmd, stdout=logfile, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    rung.process_time_s = time.perf_counter() - t0
    rung.exit_code = proc.returncode
    rung.peak_memory_mb = usage.ru_maxrss / 1024.0  # Linux: KiB
    rung.cpu_time_s = usage.ru_utime + usage.ru_stime
    rung.memory_note = "peak resident memory of the rung's own process"
    path = folder / "results.json"
    return read_json(path) if path.exists() else None


def _run_inprocess(scene: Scene, rung: Rung, folder: Path, comm: Any) -> dict[str, Any] | None:
    from mpi4py import MPI

    from suture_fem.support.errors import SutureFemError

    t0 = time.perf_counter()
    cpu0 = resource.getrusage(resource.RUSAGE_SELF)
    try:
        results = solve_rung(scene, folder, comm)
        rung.exit_code = 0
    except SutureFemError as exc:
        rung.exit_code = exc.exit_code
        results = None
    rung.process_time_s = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_SELF)
    rung.cpu_time_s = comm.allreduce(cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime, op=MPI.SUM)
    peak = cpu1.ru_maxrss / 1024.0
    rung.peak_memory_mb = comm.allreduce(peak, op=MPI.SUM)
    rung.memory_note = "in-process: peak of this process so far, summed over ranks (not the rung's own)"
    if results is None:
        path = folder / "results.json"
        results = comm.bcast(read_json(path) if comm.rank == 0 and path.exists() else None, root=0)
    return results


def singular_points(geometry: Any, fillet_mm: float) -> list[tuple[float, float]]:
    """Every point (mm) where the elastic field of the model is singular.

    The sharp cone corners (the base rim corners are not, when ``geometry.cone_fillet_mm`` > 0 rounds
    them), every point where a cone's outline meets the thread surface, and every point where an
    interface or the clamped outer surface meets a free end face of the tissue (z = 0 and z = L): the
    thread surface, the hypodermis-dermis and dermis-epidermis interfaces and the clamped surface
    r = r_epidermis. At each, a re-entrant corner, a bonded material interface or a change of
    boundary condition meets a free boundary.
    """
    r_t = geometry.r_thread
    points = list(geometry.corners)
    if fillet_mm > 0:
        points = [p for p in points if not any(abs(p[1] - c.base_z) < 1e-9 for c in geometry.cones)]
    for cone in geometry.cones:
        for _, segment in cone.outline:
            points += [tuple(q) for q in segment if abs(q[0] - r_t) < 1e-9 and tuple(q) not in points]
    radii = (r_t, geometry.r_hypodermis, geometry.r_dermis, geometry.r_epidermis)
    return points + [(r, z) for r in radii for z in (0.0, geometry.length)]


def singular_free_maxima(outputs: Any, fillet_mm: float) -> dict[str, Any]:
    """The tissue's maximum von Mises stress and equivalent strain (cell maxima over quadrature points)
    over the cells whose midpoint is farther than each of :data:`SINGULAR_FREE_MM` from every
    singular point (collective). A maximum taken away from every singularity has a limit.
    """
    import dolfinx.mesh
    import numpy as np

    from suture_fem.geometry import mesh as meshmod
    from suture_fem.geometry import regions

    physics = outputs.physics
    mesh, comm = physics.mesh, physics.comm
    points = np.array(singular_points(physics.tagged.geometry, fillet_mm), dtype=float).reshape(-1, 2)
    cells = meshmod.region_cells(physics.tagged, regions.TISSUE)
    cells = cells[cells < mesh.topology.index_map(mesh.topology.dim).size_local]
    mid = dolfinx.mesh.compute_midpoints(mesh, mesh.topology.dim, cells)[:, :2] / regions.MM
    dist = np.min(np.linalg.norm(mid[:, None, :] - points[None, :, :], axis=2), axis=1) if len(cells) else mid[:, 0]
    fields = outputs.cell_maxima()
    out: dict[str, Any] = {"singular_points_mm": points.tolist()}
    for d in SINGULAR_FREE_MM:
        far = dist > d
        for name, key in (("seqv_pa", "von_mises_pa"), ("eptoeqv", "eptoeqv")):
            vals = fields[key][cells[far]]
            k = int(np.argmax(vals)) if len(vals) else -1
            local = (float(vals[k]), mid[far][k].tolist()) if k >= 0 else (-np.inf, None)
            value, at = max(comm.allgather(local), key=lambda t: t[0])
            out[f"tissue_{name}_beyond_{_beyond(d)}"] = value if at is not None else None
            out[f"tissue_{name}_beyond_{_beyond(d)}_at_mm"] = at
    return out


def solve_rung(scene: Scene, folder: Path | None, comm: Any) -> dict[str, Any]:
    """``run_scene`` plus, at every reported force, the singularity-free maxima under ``ledger``;
    results.json is rewritten with them (rank 0).
    """
    from suture_fem.pipeline import run_scene

    extra: dict[float, dict[str, Any]] = {}
    fillet = scene.geometry.cone_fillet_mm

    def on_report(force_n: float, outputs: Any) -> None:
        if {"seqv", "eptoeqv"} <= set(getattr(outputs, "quantities", ("seqv", "eptoeqv"))):
            extra[force_n] = singular_free_maxima(outputs, fillet)

    results = run_scene(scene, folder, comm, on_report=on_report)
    for rec in results.get("at_forces", []):
        if rec["force_n"] in extra:
            rec["ledger"] = extra[rec["force_n"]]
    if folder is not None:
        on_root(comm, "writing results.json", write_json, Path(folder) / "results.json", results)
    return results


@dataclass
class Ladder:
    """What to solve: a scene source with overrides, and the rungs."""

    source: str
    overrides: list[str]
    degrees: list[int]
    refinements: list[int]
    formulations: list[str | None]
    forces: list[float]
    refine: str = "all"  # "all": level k is mesh.refinement = k; "rim": mesh.size_rim_mm / 2^k only
    caps: dict[int, int] = field(default_factory=dict)  # degree -> finest level solved

    def level_overrides(self, level: int) -> list[str]:
        if self.refine == "all":
            return [f"mesh.refinement={level}"]
        base = load_scene(self.source, self.overrides).mesh.size_rim_mm
        return [f"mesh.size_rim_mm={base / REFINEMENT_RATIO**level!r}"]

    def rungs(self) -> list[tuple[Rung, dict[str, Any]]]:
        """Every valid (rung, resolved scene); combinations the scene rejects are skipped with a log line."""
        out = []
        for formulation in self.formulations:
            for degree in self.degrees:
                for refinement in self.refinements:
                    if refinement > self.caps.get(degree, refinement):
                        continue
                    level = "r" if self.refine == "all" else "rim"
                    extra = [f"mesh.degree={degree}", *self.level_overrides(refinement)]
                    if formulation is not None:
                        extra.append(f"{FORMULATION_KEY}={json.dumps(formulation)}")
                    name = f"p{degree}_{level}{refinement}" + (f"_{formulation}" if formulation else "")
                    rung = Rung(name, degree, refinement, formulation, [*self.overrides, *extra], level)
                    try:
                        scene = load_scene(self.source, rung.overrides)
                    except SceneError as exc:
                        log.info("convergence: rung %s skipped: %s", rung.label, exc)
                        continue
                    out.append((rung, scene))
        return out


def solve_ladder(ladder: Ladder, out: Path, comm: Any, inprocess: bool, redo: bool,
                 report_only: bool = False) -> list[Rung]:
    """Solve (or reuse) every rung; returns them in order.

    ``report_only``: solve nothing; take every rung found in ``out`` as it is, even when its scene is
    no longer the one the current defaults resolve to (the ledger then says so).
    """
    done = []
    plan = ladder.rungs()
    for i, (rung, scene) in enumerate(plan, 1):
        folder = out / "rungs" / rung.name
        record = folder / "rung.json"
        if (report_only or not redo) and record.exists():
            old = read_json(record)
            same = old.get("scene") == json.loads(json.dumps(scene.as_dict()))
            if report_only or (old.get("status") == "converged" and same and old.get("version") == RUNG_VERSION):
                kept = Rung(**{k: v for k, v in old.items() if k in Rung.__dataclass_fields__})
                if (folder / "results.json").exists():
                    _collect(kept, read_json(folder / "results.json"))
                if not same:
                    kept.memory_note += "; solved with a scene that differs from today's resolved one"
                log.info("convergence: [%d/%d] %s reused from %s", i, len(plan), rung.label, record)
                done.append(kept)
                continue
        if report_only:
            continue
        if comm.rank == 0:
            folder.mkdir(parents=True, exist_ok=True)
        comm.barrier()
        log.info("convergence: [%d/%d] solving %s", i, len(plan), rung.label)
        load_before = os.getloadavg()[0]
        if inprocess or comm.size > 1:
            results = _run_inprocess(scene, rung, folder, comm)
        else:
            results = _run_subprocess(ladder.source, rung, folder)
        rung.load_average = [load_before, os.getloadavg()[0]]
        if results is not None:
            _collect(rung, results)
        else:
            rung.status = "failed"
        log.info("convergence: %s %s in %.1f s, %s dofs, %s MB", rung.label, rung.status,
                 rung.wall_time_s or float("nan"), rung.dofs, f"{rung.peak_memory_mb:.0f}" if rung.peak_memory_mb else "?")
        if comm.rank == 0:
            write_json(record, {**asdict(rung), "scene": scene.as_dict()})
        done.append(rung)
    return done


# ------------------------------------------------------------------------------------------ ledger


def _ladder_key(rung: Rung) -> str:
    return f"P{rung.degree}" + (f" {rung.formulation}" if rung.formulation else "")


def analyse(rungs: list[Rung], forces: Sequence[float]) -> dict[str, Any]:
    """Richardson estimates per ladder, the reference value and every rung's error, per force and quantity."""
    ladders: dict[str, list[Rung]] = {}
    for rung in rungs:
        if rung.status == "converged":
            ladders.setdefault(_ladder_key(rung), []).append(rung)
    for seq in ladders.values():
        seq.sort(key=lambda r: r.refinement)
    analysis: dict[str, Any] = {}
    for force in forces:
        fk = _force_key(force)
        per_q: dict[str, Any] = {}
        for q in QUANTITIES:
            estimates: dict[str, Any] = {}
            for key, seq in ladders.items():
                values = [r.values.get(fk, {}).get(q.path) for r in seq]
                # the consecutive run of refinements with a value, up to the finest
                pairs = [(r.refinement, v) for r, v in zip(seq, values) if v is not None]
                contiguous = _contiguous_tail(pairs)
                est = richardson([v for _, v in contiguous], settled_rel=SETTLED_REL, min_order=MIN_ORDER)
                estimates[key] = {
                    "refinements": [k for k, _ in contiguous],
                    "values": [v for _, v in contiguous],
                    **asdict(est),
                    "changes_rel": [abs(b - a) / abs(b) if b else None
                                    for (_, a), (_, b) in zip(contiguous, contiguous[1:])],
                }
            good = {k: e for k, e in estimates.items() if e["verdict"] in ("converging", "settled")}
            reference = None
            if good:
                best = min(good, key=lambda k: abs(good[k]["correction"]))
                reference = {"value": good[best]["limit"], "from": best, "correction": good[best]["correction"]}
            errors: dict[str, Any] = {}
            for key, seq in ladders.items():
                prev = None
                for r in seq:
                    v = r.values.get(fk, {}).get(q.path)
                    entry: dict[str, Any] = {"value": v}
                    if v is not None and reference is not None and reference["value"]:
                        entry["error_rel"] = abs(v - reference["value"]) / abs(reference["value"])
                    if v is not None and prev is not None and prev[0] == r.refinement - 1:
                        entry["two_rung_estimate_rel"] = two_rung_error(v, prev[1]) / abs(v) if v else None
                    errors[r.name] = entry
                    prev = (r.refinement, v) if v is not None else None
            verdict = _verdict(estimates, reference, q.unit)
            per_q[q.path] = {"label": q.label, "unit": q.unit, "estimates": estimates, "reference": reference,
                             "rungs": errors, "verdict": verdict}
        analysis[fk] = per_q
    return analysis


def _contiguous_tail(pairs: list[tuple[int, float]]) -> list[tuple[int, float]]:
    tail: list[tuple[int, float]] = []
    for k, v in reversed(pairs):
        if tail and tail[0][0] != k + 1:
            break
        tail.insert(0, (k, v))
    return tail


def _verdict(estimates: dict[str, Any], reference: dict[str, Any] | None, unit: str) -> str:
    """One sentence: does the quantity converge, and do the other ladders agree with the reference?"""
    kinds = {e["verdict"] for e in estimates.values()}
    finest = "; finest values " + ", ".join(f"{k}: {_fmt(e['values'][-1], unit)}" for k, e in estimates.items()
                                             if e["values"]) if len(estimates) > 1 else ""
    agreement, confirmed = "", True
    if reference is not None:
        notes = []
        for key, e in estimates.items():
            if key == reference["from"] or not e["values"]:
                continue
            off = abs(e["values"][-1] - reference["value"]) / abs(reference["value"])
            last = e["changes_rel"][-1] if e["changes_rel"] else None
            # another ladder confirms the reference when its finest value lies within twice the
            # reference's own uncertainty (its Richardson correction, at least SETTLED_REL)
            ok = off <= 2 * max(abs(reference["correction"] / reference["value"]), SETTLED_REL)
            confirmed = confirmed and ok
            own = f"; its last change {100 * last:.2g} %" if last is not None else ""
            notes.append(f"{key} finest {100 * off:.2g} % from it ({'confirms' if ok else 'does NOT confirm'}{own})")
        agreement = ("; " + ", ".join(notes)) if notes else ""
    if "converging" in kinds or "settled" in kinds:
        orders = ", ".join(f"{k}: {e['order']:.2f}" for k, e in estimates.items() if e["verdict"] == "converging")
        head = (f"converges (observed order {orders})" if orders else
                f"settled: changes below {100 * SETTLED_REL:g} % per refinement (no order measurable)")
        if not confirmed:
            head = f"not settled: the {reference['from']} ladder suggests a limit ({head}) that another degree contradicts"
        return head + agreement
    if "diverging" in kinds:
        return f"no limit in sight: the change per refinement does not shrink (observed order <= {MIN_ORDER:g}){finest}"
    if "oscillating" in kinds:
        return f"not monotone under refinement: no Richardson estimate{finest}"
    return f"too few rungs to tell{finest}"


def within(analysis: dict[str, Any], rungs: list[Rung], force: float, path: str, tol: float) -> dict[str, Any]:
    """Per ladder, the coarsest rung whose error is within ``tol`` (relative), with its cost."""
    per = analysis[_force_key(force)][path]
    found: dict[str, Any] = {}
    for rung in sorted(rungs, key=lambda r: (r.degree, r.refinement)):
        err = per["rungs"].get(rung.name, {}).get("error_rel")
        key = _ladder_key(rung)
        if err is not None and err <= tol and key not in found:
            found[key] = {"rung": rung.name, "refinement": rung.refinement, "error_rel": err,
                          "wall_time_s": rung.wall_time_s, "cpu_time_s": rung.cpu_time_s, "dofs": rung.dofs,
                          "peak_memory_mb": rung.peak_memory_mb}
    return found


def _fmt(v: float | None, unit: str) -> str:
    if v is None:
        return "-"
    if unit == "Pa":
        return f"{v / 1e3:.4g} kPa" if abs(v) < 1e6 else f"{v / 1e6:.4g} MPa"
    return f"{v:.4g}" + (f" {unit}" if unit not in ("-", "") else "")


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.2g} %"


def markdown(title: str, ladder: Ladder, rungs: list[Rung], analysis: dict[str, Any], tol: float = 0.01) -> str:
    lines = [f"# Accuracy-cost ledger: {title}", ""]
    lines += [
        f"Scene `{ladder.source}`" + (" with " + ", ".join(f"`{o}`" for o in ladder.overrides) if ladder.overrides else "")
        + f"; degrees {ladder.degrees}, "
        + (f"refinements {ladder.refinements} (every element size halves per step)." if ladder.refine == "all" else
           f"rim levels {ladder.refinements} (only mesh.size_rim_mm halves per level, at the cone corners)."),
        "",
        "## Cost of each rung",
        "",
        "| rung | cells | dofs | wall time (s) | CPU time (s) | process (s) | forms (s) | peak memory (MB) | Newton its "
        "| load steps | load average | status |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- |",
    ]
    for r in rungs:
        load = "-" if not r.load_average else " / ".join(f"{v:.1f}" for v in r.load_average)
        lines.append(
            f"| {r.label} | {r.cells or '-'} | {r.dofs or '-'} | {_num(r.wall_time_s)} | {_num(r.cpu_time_s)} | "
            f"{_num(r.process_time_s)} | {_num(r.compile_time_s, 2)} | {_num(r.peak_memory_mb, 0)} | "
            f"{r.newton_iterations or '-'} | "
            f"{r.load_steps or '-'} | {load} | {r.status} |"
        )
    notes = sorted({r.memory_note for r in rungs if r.memory_note})
    lines += ["", "Wall time: inside `run` (meshing, forms, load ramp, outputs); CPU time and process time: the whole "
              "command; forms: the part of the wall time spent compiling forms (near 0: they came from the disk "
              "cache, so no rung pays for another's); load average: the machine's 1-minute load before and after "
              "the rung (above the core count, other work was slowing the wall time). Memory: "
              + ("; ".join(notes) or "-") + ".", ""]
    for fk, per_q in analysis.items():
        lines += [f"## At {fk} N: value (error against the reference)", ""]
        header = "| rung | " + " | ".join(p["label"] for p in per_q.values()) + " |"
        lines += [header, "| --- |" + " ---: |" * len(per_q)]
        for r in rungs:
            cells = []
            for path, p in per_q.items():
                e = p["rungs"].get(r.name, {})
                cells.append(f"{_fmt(e.get('value'), p['unit'])} ({_pct(e.get('error_rel'))})")
            lines.append(f"| {r.label} | " + " | ".join(cells) + " |")
        ref_cells = []
        for p in per_q.values():
            ref = p["reference"]
            ref_cells.append(f"{_fmt(ref['value'], p['unit'])} (from {ref['from']}, +- "
                             f"{_pct(abs(ref['correction'] / ref['value']))})" if ref else "no limit")
        lines.append("| **reference** (+- its Richardson correction) | " + " | ".join(ref_cells) + " |")
        lines += ["", "| quantity | ladder | rungs | observed order | extrapolated | change per refinement | verdict |",
                  "| --- | --- | --- | ---: | ---: | --- | --- |"]
        for p in per_q.values():
            for key, e in p["estimates"].items():
                changes = ", ".join(_pct(c) for c in e["changes_rel"])
                order = f"{e['order']:.2f}" if e["order"] is not None else "-"
                lines.append(f"| {p['label']} | {key} | r{e['refinements'][0] if e['refinements'] else '-'}"
                             f"-r{e['refinements'][-1] if e['refinements'] else '-'} | {order} | "
                             f"{_fmt(e['limit'], p['unit'])} | {changes} | {e['verdict']} |")
        lines += ["", "Verdicts: " + "; ".join(f"{p['label']}: {p['verdict']}" for p in per_q.values()) + ".", ""]
        usum = within(analysis, rungs, float(fk), "usum_mm", tol)
        if usum:
            lines.append(f"USUM within {100 * tol:g} % of the reference: " + "; ".join(
                f"{k} from refinement {v['refinement']} ({_num(v['wall_time_s'])} s wall, {_num(v['cpu_time_s'])} s CPU, "
                f"{v['dofs']} dofs, "
                f"error {_pct(v['error_rel'])})" for k, v in usum.items()) + ".")
            lines.append("")
        checks = [(r, per_q["usum_mm"]["rungs"].get(r.name, {})) for r in rungs]
        checks = [(r, e) for r, e in checks if e.get("two_rung_estimate_rel") is not None and "error_rel" in e]
        if checks:
            lines += ["`run --error-estimate` (order 1 assumed: +- |USUM_h - USUM_2h|) against the error measured "
                      "here:", "", "| rung | +- (two rungs) | error against the reference | covered |",
                      "| --- | ---: | ---: | --- |"]
            lines += [f"| {r.label} | {_pct(e['two_rung_estimate_rel'])} | {_pct(e['error_rel'])} | "
                      f"{'yes' if e['two_rung_estimate_rel'] >= e['error_rel'] else 'no'} |" for r, e in checks]
            lines.append("")
    return "\n".join(lines)


def _num(v: float | None, digits: int = 1) -> str:
    return "-" if v is None else f"{v:.{digits}f}"


#: What the ledger's plot puts on its time axis (``--time``).
TIME_AXES = {"wall": ("wall_time_s", "wall time per solve (s)"),
             "cpu": ("cpu_time_s", "CPU time per solve (s): the wall time on an otherwise idle core")}


def plot(path: Path, title: str, rungs: list[Rung], analysis: dict[str, Any], time_axis: str = "wall") -> None:
    """Relative error against time per solve, log-log: one curve per quantity and ladder, one panel per force.

    Quantities without a limit are drawn dashed as their relative change per refinement.
    """
    time_key, xlabel = TIME_AXES[time_axis]
    from matplotlib import rcParams

    from suture_fem.plots import file_figure  # no pyplot: a notebook's backend is left alone

    forces = list(analysis)
    n_curves = sum(len(p["estimates"]) for p in next(iter(analysis.values()), {}).values())
    legend_rows = math.ceil(n_curves / 2)
    height = 5.0 + 0.2 * legend_rows
    fig = file_figure(figsize=(max(12.0, 6.5 * len(forces)), height))
    axes = fig.subplots(1, len(forces), squeeze=False)
    by_name = {r.name: r for r in rungs}
    colors = rcParams["axes.prop_cycle"].by_key()["color"]
    markers = {1: "o", 2: "s"}
    for ax, fk in zip(axes[0], forces):
        for qi, (path_q, p) in enumerate(analysis[fk].items()):
            color = colors[qi % len(colors)]
            for key in p["estimates"]:
                seq = [by_name[n] for n in p["rungs"] if n in by_name and _ladder_key(by_name[n]) == key]
                seq.sort(key=lambda r: r.refinement)
                if p["reference"] is not None:
                    pts = [(getattr(r, time_key), p["rungs"][r.name].get("error_rel"), r.refinement) for r in seq]
                    style, suffix = "-", ""
                else:
                    changes = p["estimates"][key]["changes_rel"]
                    pts = [(getattr(r, time_key), c, r.refinement) for r, c in zip(seq[1:], changes)]
                    style, suffix = "--", " (no limit: change per refinement)"
                pts = [(t, e, k) for t, e, k in pts if t and e]
                if not pts:
                    continue
                degree = seq[0].degree
                ax.plot([t for t, _, _ in pts], [e for _, e, _ in pts], style, color=color,
                        marker=markers.get(degree, "^"), alpha=1.0 if degree == 1 else 0.7,
                        label=f"{p['label']}, {key}{suffix}")
                for t, e, k in pts:
                    ax.annotate(f"r{k}", (t, e), textcoords="offset points", xytext=(3, 3), fontsize=7, color=color)
        ax.axhline(0.01, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("relative error (solid), change per refinement (dashed)")
        ax.set_title(f"{title}: {fk} N")
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=7, frameon=False)
    fig.tight_layout(rect=(0, (0.2 * legend_rows + 0.3) / height, 1, 1))
    tmp = path.with_name(f".{path.name}.{os.getpid()}.png")
    fig.savefig(tmp, dpi=130)
    os.replace(tmp, path)


def write_ledger(out: Path, title: str, ladder: Ladder, rungs: list[Rung], analysis: dict[str, Any]) -> dict[str, Any]:
    """Write ledger.json, ledger.md and ledger.png into ``out`` (call on one rank)."""
    from suture_fem import __version__
    from suture_fem.support import compat

    record = {
        "title": title,
        "suture_fem_version": __version__,
        "dolfinx_version": compat.DOLFINX_VERSION,
        "ladder": asdict(ladder),
        "refinement_ratio": REFINEMENT_RATIO,
        "rungs": [asdict(r) for r in rungs],
        "analysis": analysis,
        "usum_within_1_percent": {fk: within(analysis, rungs, float(fk), "usum_mm", 0.01) for fk in analysis},
    }
    write_json(out / "ledger.json", record)
    write_text(out / "ledger.md", markdown(title, ladder, rungs, analysis))
    plot(out / "ledger.png", title, rungs, analysis, "wall")
    if all(r.cpu_time_s for r in rungs if r.status == "converged"):
        plot(out / "ledger-cpu.png", title, rungs, analysis, "cpu")
    return record


# ---------------------------------------------------------------------------- run --error-estimate


def coarser_scene(scene: Scene) -> Scene:
    """The same scene one refinement coarser (every element size doubled at refinement 0)."""
    mesh = scene.mesh
    if mesh.refinement > 0:
        values: dict[str, Any] = {"mesh.refinement": mesh.refinement - 1}
    else:
        values = {f"mesh.{key}": getattr(mesh, key) * REFINEMENT_RATIO
                  for key in ("size_suture_mm", "size_rim_mm", "size_far_mm")}
    return scene.with_values({**values, "output.fields": False})


def sharp_corners(results: dict[str, Any]) -> list[tuple[float, float]]:
    """Cone corners (mm) that are sharp in this scene: all of them, except the base rim corners when
    ``geometry.cone_fillet_mm`` > 0 rounds them (the corners at a cone's base height).
    """
    geometry = results.get("geometry", {})
    corners = [tuple(c) for c in geometry.get("corners_mm", [])]
    if results.get("scene", {}).get("geometry", {}).get("cone_fillet_mm", 0.0) > 0:
        bases = [c["base_z_mm"] for c in geometry.get("cones", [])]
        corners = [c for c in corners if not any(abs(c[1] - z) < 1e-9 for z in bases)]
    return corners


def attach_error_estimate(scene: Scene, results: dict[str, Any], comm: Any, out: Path | None = None,
                          order: float = 1.0) -> dict[str, Any]:
    """Solve the scene one refinement coarser and add ``error_estimate`` to ``results`` (returned);
    with ``out``, rewrite ``out/results.json`` with it (rank 0, atomically).

    For each quantity at each reported force: value +- |Q_h - Q_2h| / (2^p - 1) with the assumed
    order p. The raw maximum stress at a sharp rim has no limit; its entry says so instead.
    """
    from suture_fem.pipeline import run_scene

    coarse_scene = coarser_scene(scene)
    log.info("error estimate: solving the scene once more, one refinement coarser")
    coarse = run_scene(coarse_scene, None, comm)
    corners = sharp_corners(results)
    exclusion = scene.output.rim_exclusion_mm
    estimate: dict[str, Any] = {
        "method": (f"Richardson with an assumed order p = {order:g}: |Q_h - Q_2h| / (2^p - 1), Q_2h from a second "
                   "solve with every element size doubled"),
        "coarse_mesh": {"refinement": coarse_scene.mesh.refinement,
                        "sizes_mm": {k: getattr(coarse_scene.mesh, k) for k in ("size_suture_mm", "size_rim_mm", "size_far_mm")},
                        "dofs": coarse.get("dofs"), "wall_time_s": coarse.get("wall_time_s")},
        "at_forces": [],
    }
    for rec in results.get("at_forces", []):
        crec = next((c for c in coarse.get("at_forces", []) if abs(c["force_n"] - rec["force_n"]) < 1e-9), None)
        if crec is None:
            continue
        entry: dict[str, Any] = {"force_n": rec["force_n"]}
        for q in QUANTITIES:
            fine, rough = q.of(rec), q.of(crec)
            if fine is None or rough is None:
                continue
            at = q.where(rec)
            if q.path != "usum_mm" and at is not None and any(math.dist(at, c) <= exclusion for c in corners):
                entry[q.path] = {"value": fine, "coarse_value": rough, "plus_minus": None, "at_mm": list(at),
                                 "note": f"maximum within output.rim_exclusion_mm = {exclusion:g} mm of a sharp cone "
                                         "corner: a singularity, no limit to estimate (use the *_outside_rim "
                                         "measures, or round the rim with geometry.cone_fillet_mm)"}
                continue
            entry[q.path] = {"value": fine, "coarse_value": rough, "plus_minus": two_rung_error(fine, rough, order)}
        estimate["at_forces"].append(entry)
    last = estimate["at_forces"][-1] if estimate["at_forces"] else None
    if last is not None and "usum_mm" in last:
        u = last["usum_mm"]
        estimate["usum_text"] = f"USUM = {u['value']:.4g} mm +- {u['plus_minus']:.2g} mm at {last['force_n']:g} N"
    results["error_estimate"] = estimate
    if out is not None:
        on_root(comm, "writing results.json", write_json, Path(out) / "results.json", results)
    return results


# ------------------------------------------------------------------------------------------- CLI


def _int_list(text: str) -> list[int]:
    try:
        return sorted({int(t) for t in text.split(",") if t.strip()})
    except ValueError:
        raise SceneError(f"expected a comma-separated list of integers, got {text!r}") from None


def _float_list(text: str) -> list[float]:
    try:
        return sorted({float(t) for t in text.split(",") if t.strip()})
    except ValueError:
        raise SceneError(f"--forces: expected a comma-separated list of forces in N, got {text!r}") from None


def register(subparsers: Any, scene_args: Any) -> None:
    p = subparsers.add_parser("ledger-rung", help="one rung of `convergence`: `run` plus the tissue's maxima away "
                              "from every singular point (results.json, at_forces[].ledger)")
    scene_args(p)
    p.add_argument("--out", required=True, help="output folder")
    p.set_defaults(handler=_rung_main)
    p = subparsers.add_parser("convergence", help="the accuracy-cost ledger: a ladder of refinements and degrees, "
                              "Richardson error estimates, wall time and memory per rung")
    scene_args(p)
    p.add_argument("--out", default=None, help="output folder (default: results/<scene name>-convergence)")
    p.add_argument("--degrees", default="1,2", help="element degrees (default 1,2)")
    p.add_argument("--refinements", default="0,1,2", help="refinement levels (default 0,1,2; three give an observed order)")
    p.add_argument("--refine", choices=("all", "rim"), default="all",
                   help="all: level k is mesh.refinement = k (every size halves); rim: only mesh.size_rim_mm "
                        "is halved k times, at the scene's refinement (what local refinement at the cone rims buys)")
    p.add_argument("--cap", action="append", default=[], metavar="DEGREE=LEVEL",
                   help="finest level solved for a degree, e.g. --cap 2=1 (degree-2 rungs above refinement 1 are too slow)")
    p.add_argument("--formulations", default=None,
                   help=f"values of {FORMULATION_KEY} to compare, e.g. displacement,mixed (default: the scene's)")
    p.add_argument("--forces", default=None, help="forces (N) to tabulate (default: every reported force and the peak)")
    p.add_argument("--title", default=None, help="title of the ledger (default: the scene name)")
    p.add_argument("--inprocess", action="store_true", help="solve the rungs in this process (automatic under mpirun)")
    p.add_argument("--redo", action="store_true", help="solve every rung again even if its folder holds a result")
    p.add_argument("--report-only", action="store_true",
                   help="solve nothing: rebuild the ledger from the rungs already in the output folder")
    p.set_defaults(handler=main)


def _rung_main(args: argparse.Namespace, comm: Any) -> int:
    solve_rung(load_scene(args.scene, args.overrides), Path(args.out), comm)
    return 0


def main(args: argparse.Namespace, comm: Any) -> int:
    base = load_scene(args.scene, args.overrides)  # bad input stops here, before any solve
    degrees = _int_list(args.degrees)
    refinements = _int_list(args.refinements)
    for d in degrees:
        RULES["mesh.degree"].check("mesh.degree", d)
    for k in refinements:
        RULES["mesh.refinement"].check("mesh.refinement", k)
    formulations: list[str | None] = [None]
    if args.formulations:
        rule = RULES.get(FORMULATION_KEY)
        if rule is None:
            raise SceneError(f"--formulations: this version has no scene key {FORMULATION_KEY}")
        formulations = [rule.check(FORMULATION_KEY, f.strip()) for f in args.formulations.split(",")]
    loading = base["loading"]
    forces = _float_list(args.forces) if args.forces else sorted(set(loading["report_forces_n"]) | {loading["force_n"]})
    off = [f for f in forces if f > loading["force_n"] or (f not in loading["report_forces_n"] and f != loading["force_n"])]
    if off:
        raise SceneError(f"--forces {args.forces}: {off} not on the ramp; allowed: loading.report_forces_n and "
                         f"loading.force_n = {sorted(set(loading['report_forces_n']) | {loading['force_n']})}")
    name = Path(args.scene).stem if args.scene.endswith(".toml") else args.scene
    out = Path(args.out or f"results/{name}-convergence")
    caps = {}
    for text in args.cap:
        degree, _, level = text.partition("=")
        if not (degree.strip().isdigit() and level.strip().isdigit()):
            raise SceneError(f"--cap {text!r}: expected DEGREE=LEVEL, for example 2=1")
        caps[int(degree)] = int(level)
    ladder = Ladder(args.scene, list(args.overrides), degrees, refinements, formulations, forces, args.refine, caps)
    rungs = solve_ladder(ladder, out, comm, args.inprocess, args.redo, args.report_only)
    analysis = analyse(rungs, forces)
    title = args.title or name
    if comm.rank == 0:
        write_ledger(out, title, ladder, rungs, analysis)
        print(f"suture-fem: ledger in {out / 'ledger.md'} ({out / 'ledger.json'}, {out / 'ledger.png'})")
        for fk, per_q in analysis.items():
            for p in per_q.values():
                print(f"  {fk} N  {p['label']}: {p['verdict']}")
    return 0 if all(r.status == "converged" for r in rungs) else 3
