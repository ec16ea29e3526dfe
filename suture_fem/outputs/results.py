"""The results of one run, typed, and their JSON form (``results.json``).

:class:`Results` is built once per run and filled as the load ramp goes: after every converged step
(:meth:`Results.step`), at every reported force (:meth:`Results.report`), and when the ramp ends
(:meth:`Results.finish`) or stops (:meth:`Results.stop`). :meth:`Results.to_dict` is the JSON form,
which repeats the last report's entries at top level; a Results also reads like that dict
(``results["usum_mm"]``, ``results.get("at_forces")``, ``"seqv_pa" in results``), read-only.

Typed, the same answers are attributes: ``results.usum_mm``, ``results.seqv_pa``, ``results.eptoeqv``
(the last report's), ``results.at_forces`` (one :class:`~suture_fem.outputs.report.Report` per reported
force), ``results.force_displacement``, ``results.peak("seqv_cd_pa", "tissue")`` (a
:class:`~suture_fem.outputs.report.Peak`: value and where), ``results.solver`` (:class:`SolverRecord`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from suture_fem import __version__
from suture_fem.geometry import mesh as meshmod
from suture_fem.outputs.report import Peak, Report, peak_of
from suture_fem.physics.problem import Physics
from suture_fem.scene import Scene
from suture_fem.support import compat
from suture_fem.support.errors import SolveStopped
from suture_fem.support.io import read_json, this_process, write_json
from suture_fem.support.parallel import on_root


@dataclass(frozen=True)
class Diagnosis:
    """Why a load ramp stopped.

    The cause ("cutbacks", "domain", "linear_solver", ...), the last converged force, the force of
    the failed attempt (N) and a human-readable detail.
    """

    cause: str
    load_reached_n: float
    attempted_n: float
    detail: str

    @classmethod
    def from_stop(cls, stop: SolveStopped) -> Diagnosis:
        """The diagnosis a SolveStopped carries."""
        return cls(stop.cause, stop.load_reached, stop.attempted, stop.detail)

    def as_dict(self) -> dict[str, Any]:
        """JSON form (``results.json``'s ``diagnosis``)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: SolverRecord's entries written only where the ramp took them.
_OPTIONAL = ("leaps", "start", "trust_region")


@dataclass(frozen=True)
class SolverRecord:
    """The solver's bookkeeping of a load ramp (from its history), as written to results.json."""

    load_steps: int
    newton_iterations: int
    cutbacks: int
    linear_solver: str
    linear_solver_fallbacks: list[str]
    domain_rejections: int
    inertia_shifts: int
    line_search_switches: int
    residual_floor_n: float
    solves_at_residual_floor: int
    leaps: int = 0
    #: the path-following start (solve/start.py), only where the ramp took one
    start: dict[str, Any] | None = None
    #: the trust region's counts (solve/trust.py), only where the ramp solved with it
    trust_region: dict[str, int] | None = None

    @classmethod
    def from_history(cls, history: Any) -> SolverRecord:
        """From the ramp's history (its RampResult, complete or up to a stop)."""
        return cls(
            load_steps=len(history.steps),
            newton_iterations=history.newton_iterations,
            cutbacks=history.cutbacks,
            linear_solver=history.linear_solver,
            linear_solver_fallbacks=history.fallbacks,
            domain_rejections=history.domain_rejections,
            inertia_shifts=history.inertia_shifts,
            line_search_switches=history.line_search_switches,
            residual_floor_n=history.residual_floor_n,
            solves_at_residual_floor=history.floor_above_atol,
            leaps=getattr(history, "leaps", 0),
            start=getattr(history, "start", None),
            trust_region=_taken(getattr(history, "trust_region", None)),
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON form (top-level keys of results.json; ``leaps``, ``start``, ``trust_region`` only where taken)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in _OPTIONAL or getattr(self, f.name)}


def _taken(counts: dict[str, int] | None) -> dict[str, int] | None:
    """The trust region's counts where it solved at least once, else None (not written)."""
    return dict(counts) if counts and counts.get("solves") else None


@dataclass(eq=False)
class Results(Mapping):
    """What one run computed; ``status`` is "running", "converged", "stopped", "interrupted" or "failed".

    Attributes:
        run: versions, MPI ranks, degrees of freedom, unknowns, the mesh's cells and sizes, the
            geometry and the applied force.
        effects: what each effect built (``Physics.effects_record``).
        scene: the scene solved (``Scene.as_dict``).
        force_displacement: [F (N), thread end displacement (mm)] after every converged step, from [0, 0].
        time_history: with inertia, [t (s), F (N), thread end displacement (mm)] after every step.
        records: the outputs record at every reported force (``at_forces``: the same, typed).
        latest: the reports' entries but ``force_n``, merged in order (so the last report's values).
        force_reached_n: the force of the last report.
        wall_time_s, timings_s: stamped at every write.
        solver: the solver's bookkeeping, once the ramp ended or stopped.
        diagnosis: why the ramp stopped.
        error: why the run was interrupted or failed (one line).
    """

    run: dict[str, Any]
    effects: dict[str, Any]
    scene: dict[str, Any]
    status: str = "running"
    force_displacement: list[list[float]] = field(default_factory=lambda: [[0.0, 0.0]])
    time_history: list[list[float]] | None = None
    records: list[dict[str, Any]] = field(default_factory=list)
    latest: dict[str, Any] = field(default_factory=dict)
    force_reached_n: float | None = None
    wall_time_s: float | None = None
    timings_s: dict[str, float] | None = None
    solver: SolverRecord | None = None
    diagnosis: Diagnosis | None = None
    error: str | None = None

    @classmethod
    def read(cls, path: str | Path) -> Results:
        """The Results a run wrote (``results.json``), typed again: ``Results.read(out / "results.json").at_forces``."""
        return cls.from_dict(read_json(path))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Results:
        """From the JSON form (:meth:`to_dict`; ``results.json``): ``Results.from_dict(d).to_dict() == d``."""
        rest = dict(data)
        records = rest.pop("at_forces", [])
        latest: dict[str, Any] = {}
        for record in records:
            latest.update({k: v for k, v in record.items() if k != "force_n"})
        for name in latest:  # the last report's entries, repeated at top level
            rest.pop(name, None)
        names = [f.name for f in fields(SolverRecord) if f.name not in _OPTIONAL]  # those: written only when taken
        solver = (SolverRecord(**{n: rest.pop(n) for n in names}, leaps=rest.pop("leaps", 0),
                               start=rest.pop("start", None), trust_region=rest.pop("trust_region", None))
                  if all(n in rest for n in names) else None)
        diagnosis = rest.pop("diagnosis", None)
        return cls(effects=rest.pop("effects"), scene=rest.pop("scene"), status=rest.pop("status"),
                   force_displacement=rest.pop("force_displacement"), time_history=rest.pop("time_history", None),
                   records=list(records), latest=latest, force_reached_n=rest.pop("force_reached_n", None),
                   wall_time_s=rest.pop("wall_time_s", None), timings_s=rest.pop("timings_s", None), solver=solver,
                   diagnosis=Diagnosis(**diagnosis) if diagnosis is not None else None, error=rest.pop("error", None),
                   run=rest)

    @classmethod
    def start(cls, scene: Scene, physics: Physics, comm: Any) -> Results:
        """A running run's results: its metadata, nothing solved yet (collective: counts the cells)."""
        run = {
            "suture_fem_version": __version__,
            "dolfinx_version": compat.DOLFINX_VERSION,
            "mpi_ranks": comm.size,
            "dofs": physics.num_dofs(),
            "unknowns": physics.num_unknowns(),
            **meshmod.describe(physics.tagged),
            **({"applied_force_n": scene.loading.force_n} if scene.loading.control == "force" else
               {"control": "displacement", "applied_displacement_mm": scene.loading.displacement_mm}),
            "process": this_process(),  # pid, host, start: a reader can tell a dead "running" from a live one
        }
        return cls(run=run, effects=physics.effects_record(), scene=scene.as_dict())

    def step(self, force_n: float, thread_end_mm: float, time_s: float | None = None) -> None:
        """A converged load step: its point of the force-displacement curve (and of the time history)."""
        self.force_displacement.append([force_n, thread_end_mm])
        if time_s is not None:  # with inertia
            if self.time_history is None:
                self.time_history = []
            self.time_history.append([time_s, force_n, thread_end_mm])

    def report(self, force_n: float, record: dict[str, Any]) -> None:
        """The outputs record of a reported force."""
        self.records.append(record)
        self.latest.update({k: v for k, v in record.items() if k != "force_n"})
        self.force_reached_n = force_n

    def needs_report(self, load_reached_n: float) -> bool:
        """Whether the last converged force of a stopped ramp still lacks its outputs record."""
        return load_reached_n > 0 and (not self.records or self.records[-1]["force_n"] < load_reached_n)

    def finish(self, history: Any) -> None:
        """The ramp reached the full load."""
        self.solver = SolverRecord.from_history(history)
        self.status = "converged"

    def stop(self, stop: SolveStopped) -> None:
        """The ramp stopped: its diagnosis, and the solver's bookkeeping when known."""
        if stop.history is not None:
            self.solver = SolverRecord.from_history(stop.history)
        self.status = "stopped"
        self.diagnosis = Diagnosis.from_stop(stop)

    def end(self, status: str, error: str) -> None:
        """The run ended without a diagnosis: "interrupted" (a signal) or "failed" (e.g. a full disk)."""
        self.status, self.error = status, error

    def write(self, path: Path | None, comm: Any, wall_time_s: float, timings_s: dict[str, float]) -> None:
        """Stamp the times; with a path, write the JSON form there atomically (rank 0)."""
        self.wall_time_s, self.timings_s = wall_time_s, timings_s
        if path is not None:
            on_root(comm, f"writing {path}", write_json, path, self.to_dict())

    def to_dict(self) -> dict[str, Any]:
        """The JSON form: the keys and values of results.json."""
        out: dict[str, Any] = {"status": self.status, **self.run, "force_displacement": self.force_displacement,
                               "at_forces": self.records, "effects": self.effects, "scene": self.scene}
        if self.time_history is not None:
            out["time_history"] = self.time_history
        if self.wall_time_s is not None:
            out["wall_time_s"], out["timings_s"] = self.wall_time_s, self.timings_s
        out.update(self.latest)
        if self.force_reached_n is not None:
            out["force_reached_n"] = self.force_reached_n
        if self.solver is not None:
            out.update(self.solver.as_dict())
        if self.diagnosis is not None:
            out["diagnosis"] = self.diagnosis.as_dict()
        if self.error is not None:
            out["error"] = self.error
        return out

    @property
    def at_forces(self) -> list[Report]:
        """The outputs at every reported force, in order."""
        return [Report(record) for record in self.records]

    @property
    def usum_mm(self) -> float | None:
        """USUM at the last reported force (mm; None before the first report)."""
        return self.latest.get("usum_mm")

    @property
    def seqv_pa(self) -> float | None:
        """SEQV at the last reported force (Pa; None before the first report or without SEQV)."""
        return self.latest.get("seqv_pa")

    @property
    def eptoeqv(self) -> float | None:
        """EPTOEQV at the last reported force (None before the first report or without EPTOEQV)."""
        return self.latest.get("eptoeqv")

    @property
    def regions(self) -> dict[str, Any]:
        """Each region's measures at the last reported force."""
        return self.latest.get("regions", {})

    def peak(self, measure: str, region: str | None = None) -> Peak:
        """The maximum of ``measure`` at the last reported force and where it is (KeyError if not computed)."""
        return peak_of(self.latest, measure, region)

    def __getitem__(self, key: str) -> Any:
        """The JSON form's entry (KeyError where it has none)."""
        return self.to_dict()[key]

    def __iter__(self) -> Iterator[str]:
        """The JSON form's keys."""
        return iter(self.to_dict())

    def __len__(self) -> int:
        """The JSON form's number of keys."""
        return len(self.to_dict())
