"""What a run keeps of its load steps: results.json after every step, the field files, the report hook.

:class:`LoadSteps` is what a solve hands the load ramp (its ``on_converged``): after every converged
step the results gain a point of the force-displacement curve and results.json is rewritten
(atomically, rank 0); at every reported force the outputs are evaluated into the results, the state
is kept (a :class:`~suture_fem.outputs.snapshots.Snapshot`, for :meth:`suture_fem.model.Model.reports`),
the field files get it and ``on_report`` (if any) is called; when the ramp ends, stops, is interrupted
or fails, results.json says which. :func:`output_folder` prepares the folder first (removing what an
earlier run wrote there, :data:`OUTPUT_FILES`), so an unusable folder stops every rank before the solve.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suture_fem.outputs.evaluate import Outputs
from suture_fem.outputs.fields import FieldWriter
from suture_fem.outputs.results import Results
from suture_fem.outputs.snapshots import Snapshot
from suture_fem.scene import Scene
from suture_fem.solve.records import Timings
from suture_fem.support import signals
from suture_fem.support.errors import SolveStopped, SutureFemError
from suture_fem.support.io import remove
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")

#: ``on_report(force_n, outputs)``: called on every rank at each reported force (kept for external callers;
#: :meth:`suture_fem.model.Model.reports` gives the same states after the solve).
OnReport = Callable[[float, Outputs], None]


#: What a run writes in its output folder; removed before a new run writes there (pictures by the cli).
OUTPUT_FILES = ("results.json", "fields.xdmf", "fields.h5", ".fields.partial", "usum.png", "force_displacement.png",
                "interface.png")


@dataclass
class Clock:
    """Wall time since the run began, the meshing time, and the solver's timings."""

    start: float = field(default_factory=time.perf_counter)
    meshing: float = 0.0
    timings: Timings = field(default_factory=Timings)

    def stamp(self) -> tuple[float, dict[str, float]]:
        """(wall time so far, the ``timings_s`` record), s."""
        return time.perf_counter() - self.start, {"meshing": round(self.meshing, 4), **self.timings.as_dict()}


def output_folder(out_dir: str | Path | None, comm: Any) -> Path | None:
    """The output folder, created now: an unusable one stops every rank before the solve, not after."""
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        on_root(comm, f"creating the output folder {out}", fresh_outputs, out)
    return out


def fresh_outputs(out: Path) -> None:
    """Create ``out``; remove what an earlier run wrote there (so no stale field file stays)."""
    out.mkdir(parents=True, exist_ok=True)
    remove(*(out / name for name in OUTPUT_FILES))


class LoadSteps:
    """What the run keeps of its load steps.

    The results after every converged step, and at every reported force the outputs record, the
    state (``snapshots``, one per record of ``results.at_forces``), the field files and ``on_report``;
    results.json is rewritten after each step and when the ramp ends or stops.
    """

    def __init__(self, scene: Scene, outputs: Outputs, out: Path | None, clock: Clock, on_report: OnReport | None):
        self.outputs, self.clock, self.on_report = outputs, clock, on_report
        self.comm = outputs.physics.comm
        self.results = Results.start(scene, outputs.physics, self.comm)
        self.path = out / "results.json" if out is not None else None
        self.fields_path = out / "fields.xdmf" if out is not None and scene.output.fields else None
        self.writer: FieldWriter | None = None
        self.snapshots: list[Snapshot] = []
        self.save()  # "running", with the process that runs it, from the start

    def open_fields(self) -> None:
        """Start the field files, if the scene asks for them (collective)."""
        if self.fields_path is not None:
            self.writer = FieldWriter(self.outputs.physics, self.outputs, str(self.fields_path))

    def converged(self, force_n: float, report: bool, time_s: float | None = None) -> None:
        """After every converged step of the ramp (``time_s``: with inertia, the time reached)."""
        self.results.step(force_n, self.outputs.thread_end_displacement_mm(), time_s)
        if report:
            self.report(force_n)
        self.save()
        signals.check(self.comm)  # a signal received meanwhile (on any rank) ends the ramp after this step

    def report(self, force_n: float) -> None:
        """The outputs of the current state at a reported force (collective)."""
        t0 = time.perf_counter()
        record = self.outputs.evaluate()
        self.clock.timings.outputs += time.perf_counter() - t0
        self.results.report(force_n, record)
        self.snapshots.append(Snapshot.take(self.outputs.physics, force_n))
        if self.writer is not None:
            self.writer.write(force_n)
        if self.on_report is not None:
            self.on_report(force_n, self.outputs)

    def stopped(self, stop: SolveStopped) -> None:
        """The ramp stopped: the diagnosis, and the last converged state's outputs so they are not lost."""
        self.results.stop(stop)
        if self.results.needs_report(stop.load_reached):
            self.report(stop.load_reached)

    def ended(self, exc: BaseException) -> None:
        """The ramp ended early: stopped (a diagnosis), interrupted (a signal) or failed; results.json says which.

        The field files keep the converged reports after a stop or an interrupt; after a failure
        they are removed. A results.json that cannot be written then is logged, not raised, so the
        first error is the one reported.
        """
        with signals.held():  # a signal now must not leave results.json "running"
            self._ended(exc)

    def _ended(self, exc: BaseException) -> None:
        if isinstance(exc, SolveStopped):
            self.stopped(exc)
        elif isinstance(exc, KeyboardInterrupt):
            name = getattr(exc, "name", "SIGINT")
            self.results.end("interrupted", f"interrupted by {name} after the last converged step")
        else:
            self.results.end("failed", str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
            if self.writer is not None:
                self.writer.discard()
                self.writer = None
        try:
            self.close()
        except SutureFemError as err:
            self.results.end("failed", str(err))
        try:
            self.save()
        except SutureFemError as err:
            log.error("%s", err)

    def finished(self, history: Any) -> None:
        """The ramp reached the full load."""
        self.results.finish(history)
        self.save()

    def save(self) -> None:
        """Stamp the times and rewrite results.json (rank 0, atomically; a signal meanwhile is raised after)."""
        with signals.held():
            self.results.write(self.path, self.comm, *self.clock.stamp())

    def close(self) -> None:
        """Close the field file, if any, and move it into place (collective)."""
        writer, self.writer = self.writer, None
        if writer is not None:
            writer.close()
