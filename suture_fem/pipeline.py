"""The pipeline of one scene: scene -> geometry -> mesh -> physics -> load ramp -> outputs -> results.json.

:func:`load_scene` reads and validates a scene completely (keys, types, ranges, then the checks that
need the geometry and the effects), before any meshing; :func:`run_scene` solves it.

``results.json`` is rewritten (atomically) after every converged load step, so a run that stops
later keeps everything it had computed; its ``status`` says "running", "converged", "stopped" (a
diagnosis), "interrupted" (SIGINT, SIGTERM) or "failed" (e.g. a full disk; ``error`` says why), and
``process`` names the process that wrote it. The outputs of an earlier run in the same folder are
removed first, so no stale file stays beside new results.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.estimate import check_fits
from suture_fem.geometry.section import Geometry
from suture_fem.outputs.evaluate import Outputs
from suture_fem.outputs.fields import FieldWriter
from suture_fem.outputs.results import Results
from suture_fem.physics.effects import check_scene
from suture_fem.physics.problem import build_physics
from suture_fem.scene import Scene, parse_scene
from suture_fem.solve.records import Timings
from suture_fem.solve.stepping import ramp
from suture_fem.support.errors import SceneError, SolveStopped, StopCause, SutureFemError
from suture_fem.support.io import remove
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")

#: ``on_report(force_n, outputs)``: called on every rank at each reported force.
OnReport = Callable[[float, Outputs], None]


def load_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> Scene:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; fully validated.

    Raises SceneError (one line naming the key and its allowed range) before anything is meshed.
    """
    scene = parse_scene(source, overrides)
    check(scene)
    return scene


def check(scene: Scene) -> None:
    """The checks that need the geometry (cones that fit), the effects and the mesh's size (SceneError).

    The mesh's size is estimated before gmsh runs: a scene whose solve cannot fit in this machine's
    memory is refused in one line instead of meshing for minutes.
    """
    geometry = Geometry.from_section(scene.geometry)
    if scene.mesh.geometry_degree == 2 and scene.mesh.degree != 2:
        raise SceneError("scene key mesh.geometry_degree = 2 (quadratic cells) needs mesh.degree = 2 (isoparametric), "
                         f"got mesh.degree = {scene.mesh.degree} (reproduce's P1 mesh rungs and convergence's "
                         "degree-1 rungs set it: use --mesh scene, or --degrees 2)")
    check_scene(scene)
    log.info("mesh estimate: %s", check_fits(geometry, scene.mesh).describe())


def run_scene(scene: Scene, out_dir: str | Path | None, comm: Any, on_report: OnReport | None = None) -> Results:
    """Solve a validated scene; write ``out_dir/results.json`` (rank 0) and return its :class:`Results`.

    ``on_report(force_n, outputs)``, if given, is called (on every rank) at each reported force with
    the Outputs of the solved state, for pictures: ``outputs.physics.u`` is the displacement and
    ``outputs.cell_maxima()`` the von Mises stress and equivalent strain per cell; ``outputs.newton`` is
    the Newton solver that just converged (None in the report of a stopped ramp's last state).
    The Results read like results.json's dict (``results["usum_mm"]``); ``results.to_dict()`` is that dict.
    Raises SolveStopped after writing the converged part when the ramp cannot be completed.
    """
    clock = _Clock()
    out = _output_folder(out_dir, comm)
    outputs = _build(scene, comm, clock)
    steps = LoadSteps(scene, outputs, out, clock, on_report)
    try:
        _check_axial_support(scene)
        steps.open_fields()
        history = ramp(outputs.physics, scene, steps.converged, clock.timings, with_solver=True)
        steps.close()
    except BaseException as exc:
        steps.ended(exc)
        raise
    steps.finished(history)
    return steps.results


def _check_axial_support(scene: Scene) -> None:
    """Stop with a diagnosis when nothing can hold the pull: a thread in its own track (sliding, unilateral), no cone.

    A Coulomb thread cannot hold it either: nothing presses the tissue onto the thread before the cones do.
    """
    if scene.effects.thread_track and scene.geometry.cones == 0:
        first = scene.loading.force_n * scene.solver.initial_step
        raise SolveStopped(StopCause.NO_AXIAL_SUPPORT, 0.0, first,
                           f'effects.thread_interface = "{scene.effects.thread_interface}" with geometry.cones = 0: a '
                           "thread in its own track passes no axial force to the tissue without a cone (frictionless "
                           "it cannot; with friction nothing presses the tissue onto it before a cone does), so no "
                           "state balances a pull")


#: What a run writes in its output folder; removed before a new run writes there (pictures by the cli).
OUTPUT_FILES = ("results.json", "fields.xdmf", "fields.h5", ".fields.partial", "usum.png", "force_displacement.png",
                "interface.png")


@dataclass
class _Clock:
    """Wall time since the run began, the meshing time, and the solver's timings."""

    start: float = field(default_factory=time.perf_counter)
    meshing: float = 0.0
    timings: Timings = field(default_factory=Timings)

    def stamp(self) -> tuple[float, dict[str, float]]:
        """(wall time so far, the ``timings_s`` record), s."""
        return time.perf_counter() - self.start, {"meshing": round(self.meshing, 4), **self.timings.as_dict()}


def _output_folder(out_dir: str | Path | None, comm: Any) -> Path | None:
    """The output folder, created now: an unusable one stops every rank before the solve, not after."""
    out = Path(out_dir) if out_dir is not None else None
    if out is not None:
        on_root(comm, f"creating the output folder {out}", _fresh_outputs, out)
    return out


def _fresh_outputs(out: Path) -> None:
    """Create ``out``; remove what an earlier run wrote there (so no stale field file stays)."""
    out.mkdir(parents=True, exist_ok=True)
    remove(*(out / name for name in OUTPUT_FILES))


def _build(scene: Scene, comm: Any, clock: _Clock) -> Outputs:
    """Mesh, physics and the outputs of the scene (the physics is ``outputs.physics``), timed."""
    t0 = time.perf_counter()
    tagged = meshmod.scene_mesh(comm, scene)
    clock.meshing = time.perf_counter() - t0
    t0 = time.perf_counter()
    physics = build_physics(tagged, scene)
    outputs = Outputs(physics, scene.output, quantities=physics.effects.quantities)
    clock.timings.form_compilation += time.perf_counter() - t0
    return outputs


class LoadSteps:
    """What the run keeps of its load steps.

    The results after every converged step, and at every reported force the outputs record, the
    field files and ``on_report``; results.json is rewritten after each step and when the ramp ends
    or stops.
    """

    def __init__(self, scene: Scene, outputs: Outputs, out: Path | None, clock: _Clock, on_report: OnReport | None):
        self.outputs, self.clock, self.on_report = outputs, clock, on_report
        self.comm = outputs.physics.comm
        self.results = Results.start(scene, outputs.physics, self.comm)
        self.path = out / "results.json" if out is not None else None
        self.fields_path = out / "fields.xdmf" if out is not None and scene.output.fields else None
        self.writer: FieldWriter | None = None
        self.save()  # "running", with the process that runs it, from the start

    def open_fields(self) -> None:
        """Start the field files, if the scene asks for them (collective)."""
        if self.fields_path is not None:
            self.writer = FieldWriter(self.outputs.physics, self.outputs, str(self.fields_path))

    def converged(self, force_n: float, report: bool, time_s: float | None = None, solver: Any = None) -> None:
        """After every converged step of the ramp (``time_s``: with inertia, the time reached)."""
        self.results.step(force_n, self.outputs.thread_end_displacement_mm(), time_s)
        if report:
            self.outputs.newton = solver  # for on_report only while the solver is alive
            try:
                self.report(force_n)
            finally:
                self.outputs.newton = None
        self.save()

    def report(self, force_n: float) -> None:
        """The outputs of the current state at a reported force (collective)."""
        self.results.report(force_n, self.outputs.evaluate())
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
        """Stamp the times and rewrite results.json (rank 0, atomically)."""
        self.results.write(self.path, self.comm, *self.clock.stamp())

    def close(self) -> None:
        """Close the field file, if any, and move it into place (collective)."""
        writer, self.writer = self.writer, None
        if writer is not None:
            writer.close()
