"""The ladder of solves and what each rung cost: wall time, CPU time, memory, dofs, Newton iterations.

A ladder solves one scene refinement by refinement (every element size halves per step) for each
element degree (and each incompressibility formulation, where the scene has that choice). Its levels
may instead refine one place only, at the scene's ``mesh.refinement`` (``Ladder.refine``): "rim"
halves ``mesh.size_rim_mm`` per level (the cone corners), "fillet" doubles ``mesh.fillet_elements``
per level (the elements along each rounded base rim's arc, whose size then halves as in the others).

Each rung runs by default as its own ``suture-fem ledger-rung`` process (``suture-fem run`` plus the
tissue's maxima away from every singular point), so its peak memory (``ru_maxrss`` of that child,
from ``os.wait4``) is its own and no rung profits from forms compiled by another in memory
(compiled forms are still shared through the disk cache, as in any run). Under mpirun, or with
``inprocess``, the rungs run in this process on its communicator; the peak memory is then the
process's peak so far (summed over ranks) and says so.

Every rung writes ``rungs/<name>/`` (its results.json, run.log and rung.json). Rungs whose folder
already holds a converged result of the same resolved scene are reused (``redo`` solves them again).
"""

from __future__ import annotations

import functools
import json
import logging
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
from suture_fem.scene.schema import RULES, MeshSection
from suture_fem.studies.convergence.quantities import QUANTITIES, REFINEMENT_RATIO, force_key
from suture_fem.studies.convergence.singular import solve_rung
from suture_fem.support import children
from suture_fem.support.errors import SceneError
from suture_fem.support.io import open_new, read_json, write_json

log = logging.getLogger("suture_fem")

#: Version of what a rung records; a rung folder written by another version is solved again. Any change
#: to what an output means or which outputs a rung records bumps it (4: the near-cone critical-distance
#: averages and the disc search's coarse view, commit 2910b9e).
RUNG_VERSION = 4
#: Scene key of the incompressibility formulation, where the scene has one.
FORMULATION_KEY = "effects.incompressibility"
#: What a ladder refines (``--refine``) -> the prefix of its rungs' levels in names and labels.
LEVEL_NAMES = {"all": "r", "rim": "rim", "fillet": "fillet"}


@dataclass
class Rung:
    """One solve of the ladder and what it cost."""

    name: str
    degree: int
    refinement: int
    formulation: str | None
    overrides: list[str]
    level_name: str = "r"  # "r": mesh.refinement; "rim": halvings of mesh.size_rim_mm; "fillet": doublings of
    # mesh.fillet_elements (LEVEL_NAMES)
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
        """The rung's name in tables and logs, e.g. ``P2 r1`` or ``P1 mixed rim2``."""
        form = f" {self.formulation}" if self.formulation else ""
        return f"P{self.degree}{form} {self.level_name}{self.refinement}"


def ladder_key(rung: Rung) -> str:
    """The ladder a rung belongs to: its degree and formulation, e.g. ``P1`` or ``P2 mixed``."""
    return f"P{rung.degree}" + (f" {rung.formulation}" if rung.formulation else "")


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
        rung.values[force_key(rec["force_n"])] = {q.path: q.of(rec) for q in QUANTITIES}


def _sets(overrides: Sequence[str]) -> list[str]:
    return [a for o in overrides for a in ("--set", o)]


def _run_subprocess(source: str, rung: Rung, folder: Path) -> dict[str, Any] | None:
    """`suture-fem ledger-rung` in a child process; its own peak memory from os.wait4."""
    # -P: the current folder is not on the child's module path (a stray .py there must not run)
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "ledger-rung", source, *_sets(rung.overrides),
           "--out", str(folder)]
    t0 = time.perf_counter()
    with open_new(folder / "run.log") as logfile, children.running(cmd, stdout=logfile,
                                                                   stderr=subprocess.STDOUT) as proc:
        _, status, usage = os.wait4(proc.pid, 0)  # an interrupt here stops the child (children.running)
    proc.returncode = os.waitstatus_to_exitcode(status)
    rung.process_time_s = time.perf_counter() - t0
    rung.exit_code = proc.returncode
    rung.peak_memory_mb = usage.ru_maxrss / 1024.0  # Linux: KiB
    rung.cpu_time_s = usage.ru_utime + usage.ru_stime
    rung.memory_note = "peak resident memory of the rung's own process"
    path = folder / "results.json"
    return read_json(path) if path.exists() else None


def _run_inprocess(scene: Scene, rung: Rung, folder: Path, comm: Any) -> dict[str, Any] | None:
    """The rung solved on ``comm`` in this process (collective); its CPU time summed over ranks."""
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


@dataclass
class Ladder:
    """What to solve: a scene source with overrides, and the rungs."""

    source: str
    overrides: list[str]
    degrees: list[int]
    refinements: list[int]
    formulations: list[str | None]
    forces: list[float]
    refine: str = "all"  # "all": level k is mesh.refinement = k; "rim": mesh.size_rim_mm / 2^k only;
    # "fillet": mesh.fillet_elements * 2^k only (both at the scene's mesh.refinement)
    caps: dict[int, int] = field(default_factory=dict)  # degree -> finest level solved

    @functools.cached_property
    def base_mesh(self) -> MeshSection:
        """The ``[mesh]`` section of the scene with the ladder's overrides (loaded once)."""
        return load_scene(self.source, self.overrides).mesh

    def level_overrides(self, level: int) -> list[str]:
        """The scene keys of a level: every size halved, or only the rim size, or only the fillet's (``refine``)."""
        if self.refine == "all":
            return [f"mesh.refinement={level}"]
        mesh = self.base_mesh
        if self.refine == "fillet":
            return [f"mesh.fillet_elements={fillet_elements(mesh.fillet_elements, level)}"]
        return [f"mesh.size_rim_mm={mesh.size_rim_mm / REFINEMENT_RATIO**level!r}"]

    def rungs(self) -> list[tuple[Rung, Scene]]:
        """Every valid (rung, resolved scene); combinations the scene rejects are skipped with a log line."""
        out = []
        for formulation in self.formulations:
            for degree in self.degrees:
                for refinement in self.refinements:
                    if refinement > self.caps.get(degree, refinement):
                        continue
                    level = LEVEL_NAMES[self.refine]
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


def _reused(rung: Rung, scene: Scene, folder: Path, report_only: bool) -> Rung | None:
    """The rung recorded in ``folder`` when it may stand in for a new solve, else None.

    It may when it converged with the same resolved scene and the same :data:`RUNG_VERSION`, or,
    with ``report_only``, whatever it holds (its memory note then says when the scene differs).
    """
    old = read_json(folder / "rung.json")
    same = old.get("scene") == json.loads(json.dumps(scene.as_dict()))
    if not (report_only or (old.get("status") == "converged" and same and old.get("version") == RUNG_VERSION)):
        return None
    kept = Rung(**{k: v for k, v in old.items() if k in Rung.__dataclass_fields__})
    if (folder / "results.json").exists():
        _collect(kept, read_json(folder / "results.json"))
    if not same:
        kept.memory_note += "; solved with a scene that differs from today's resolved one"
    return kept


def _solve(ladder: Ladder, rung: Rung, scene: Scene, folder: Path, comm: Any, inprocess: bool) -> Rung:
    """Solve one rung (a child process, or in this process under mpirun or ``inprocess``) and record it."""
    if comm.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
    comm.barrier()
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
        write_json(folder / "rung.json", {**asdict(rung), "scene": scene.as_dict()})
    return rung


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
        if (report_only or not redo) and (folder / "rung.json").exists():
            kept = _reused(rung, scene, folder, report_only)
            if kept is not None:
                log.info("convergence: [%d/%d] %s reused from %s", i, len(plan), rung.label, folder / "rung.json")
                done.append(kept)
                continue
        if report_only:
            continue
        log.info("convergence: [%d/%d] solving %s", i, len(plan), rung.label)
        done.append(_solve(ladder, rung, scene, folder, comm, inprocess))
    return done


def fillet_elements(base: int, level: int) -> int:
    """Elements along each fillet arc at a level of ``--refine fillet``: the scene's count doubled ``level`` times.

    The arc's element size halves per level, so the Richardson ratio is :data:`REFINEMENT_RATIO` as for
    the other ladders.
    """
    return base * int(REFINEMENT_RATIO) ** level


def _check_fillet_levels(base: Scene, levels: Sequence[int]) -> None:
    """Refuse a ``--refine fillet`` ladder the scene cannot have: no fillet, or too many elements on an arc."""
    if base.geometry.cone_fillet_mm <= 0:
        raise SceneError("--refine fillet: the scene's rims are sharp (geometry.cone_fillet_mm = 0); "
                         "round them first, e.g. --set geometry.cone_fillet_mm=0.04")
    rule, n = RULES["mesh.fillet_elements"], base.mesh.fillet_elements
    over = [k for k in levels if fillet_elements(n, k) > rule.hi]
    if over:
        raise SceneError(f"--refine fillet: level {over[0]} would put {fillet_elements(n, over[0])} elements on each "
                         f"fillet arc (mesh.fillet_elements = {n} doubled {over[0]} times); "
                         f"mesh.fillet_elements allows at most {rule.hi:g}")


def plan_ladder(base: Scene, source: str, overrides: Sequence[str], degrees: Sequence[int],
                refinements: Sequence[int], formulations: Sequence[str] | None = None,
                forces: Sequence[float] | None = None, refine: str = "all",
                caps: dict[int, int] | None = None) -> Ladder:
    """The ladder of ``source`` with ``overrides`` (resolved to ``base``), checked before any solve.

    Degrees and refinements must be valid scene values (with ``refine`` "fillet": a rounded rim, and
    levels within ``mesh.fillet_elements``' range), every formulation a value of
    :data:`FORMULATION_KEY`, every force one the ramp reports (``loading.report_forces_n`` or
    ``loading.force_n``; default: all of them). Raises SceneError otherwise.
    """
    for option, values in (("--degrees", degrees), ("--refinements", refinements)):
        if not values:
            raise SceneError(f"{option}: expected at least one value, for example {option} 1,2 (got none)")
    for d in degrees:
        RULES["mesh.degree"].check("mesh.degree", d)
    if refine not in LEVEL_NAMES:
        raise SceneError(f"--refine {refine}: expected one of {', '.join(LEVEL_NAMES)}")
    if refine == "fillet":
        _check_fillet_levels(base, refinements)
    for k in refinements:
        RULES["mesh.refinement"].check("mesh.refinement", k)
    checked: list[str | None] = [None]
    if formulations:
        rule = RULES.get(FORMULATION_KEY)
        if rule is None:
            raise SceneError(f"--formulations: this version has no scene key {FORMULATION_KEY}")
        checked = [rule.check(FORMULATION_KEY, f) for f in formulations]
    reported, peak = base.loading.report_forces_n, base.loading.force_n
    allowed = sorted(set(reported) | {peak})
    forces = sorted(forces) if forces else allowed
    off = [f for f in forces if f > peak or (f not in reported and f != peak)]
    if off:
        raise SceneError(f"--forces {','.join(f'{f:g}' for f in forces)}: {off} not on the ramp; allowed: "
                         f"loading.report_forces_n and loading.force_n = {allowed}")
    return Ladder(source, list(overrides), list(degrees), list(refinements), checked, list(forces), refine,
                  dict(caps or {}))
