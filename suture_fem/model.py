"""The model of one scene as an object: mesh, physics and outputs built once, solved as often as asked.

    from suture_fem import Model, Scene

    model = Model(Scene.builtin("paper").with_values({"mesh.degree": 1, "loading.force_n": 1.0}))
    results = model.solve()                         # the load ramp; typed Results
    results.usum_mm, results.at_forces[-1].seqv_pa  # the answer; model.u, model.mesh: the solved state
    model.set({"materials.tissue_scale": 1.2})      # a new Constant value: no new mesh, no new form
    stiffer = model.solve()                         # from rest again, on the same mesh and forms
    warm = model.set({"materials.tissue_scale": 1.1}).solve(start="previous")  # from the last answer's states
    for report in model.reports():                  # each reported force's state, set on the model in turn
        cells = model.outputs.cell_maxima()         # stress per cell for a picture, any output of that state

:class:`Model` checks the scene (the checks that need the geometry and the mesh's size, before any
meshing), then meshes and builds the physics and the outputs once. :meth:`Model.solve` runs the load
ramp from rest exactly as ``suture-fem run`` does (:func:`suture_fem.pipeline.run_scene` is this),
writing results.json when given a folder, and keeps the state of every reported force:
:meth:`Model.reports` sets each on the model in turn (no callback into the ramp). :meth:`Model.set`
changes the keys that are dolfinx Constants of the forms (every material constant,
``materials.tissue_scale``, ``loading.force_scale``) and the ramp's ``loading.force_n`` and
``loading.report_forces_n``; any other key needs a new mesh or new forms and is refused in one line.
The Newton solver (its matrices, SNES and, once the model is solved again, the factorisation's
analysis) is built at the first solve and kept for the next ones.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.estimate import check_fits
from suture_fem.geometry.estimate_3d import check_fits_3d
from suture_fem.geometry.section import Geometry
from suture_fem.outputs.evaluate import Outputs
from suture_fem.outputs.report import Report
from suture_fem.outputs.results import Results
from suture_fem.outputs.snapshots import Snapshot
from suture_fem.outputs.steps import Clock, LoadSteps, OnReport, output_folder
from suture_fem.physics.effects import check_scene
from suture_fem.physics.effects.friction import slip_laws
from suture_fem.physics.problem import Physics, build_physics
from suture_fem.physics.three_d import check_three_d
from suture_fem.scene import Scene
from suture_fem.solve.newton import NewtonSolver
from suture_fem.solve.records import Timings
from suture_fem.solve.stepping import ramp
from suture_fem.support import signals
from suture_fem.support.errors import SceneError, SolveStopped, StopCause

log = logging.getLogger("suture_fem")

#: The keys the load ramp reads from the scene when it starts (no Constant, no form).
RAMP_KEYS = ("loading.force_n", "loading.report_forces_n", "loading.displacement_mm", "loading.report_displacements_mm")


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
    check_three_d(scene)
    found = check_fits_3d(geometry, scene.mesh, solver=scene.solver) if scene.geometry.dimension == 3 \
        else check_fits(geometry, scene.mesh)
    log.info("mesh estimate: %s", found.describe())


def _check_axial_support(scene: Scene) -> None:
    """Stop with a diagnosis when nothing can hold the pull: a thread in its own track (sliding, unilateral), no cone.

    A Coulomb thread cannot hold it either: nothing presses the tissue onto the thread before the cones do.
    Under displacement control the end simply takes no force (its reaction is reported).
    """
    if scene.effects.thread_track and scene.geometry.cones == 0 and scene.loading.control == "force":
        first = scene.loading.force_n * scene.solver.initial_step
        raise SolveStopped(StopCause.NO_AXIAL_SUPPORT, 0.0, first,
                           f'effects.thread_interface = "{scene.effects.thread_interface}" with geometry.cones = 0: a '
                           "thread in its own track passes no axial force to the tissue without a cone (frictionless "
                           "it cannot; with friction nothing presses the tissue onto it before a cone does), so no "
                           "state balances a pull")


def _build(scene: Scene, comm: Any, clock: Clock) -> Outputs:
    """Mesh, physics and the outputs of the scene (the physics is ``outputs.physics``), timed."""
    t0 = time.perf_counter()
    tagged = meshmod.scene_mesh(comm, scene)
    clock.meshing = time.perf_counter() - t0
    t0 = time.perf_counter()
    physics = build_physics(tagged, scene)
    outputs = Outputs(physics, scene.output, quantities=physics.effects.quantities)
    clock.timings.form_compilation += time.perf_counter() - t0
    return outputs


class Model:
    """One scene's mesh, physics and outputs, built once (collective over ``comm``); solved by :meth:`solve`.

    Attributes:
        scene: the scene solved (:meth:`set` replaces it with the new values).
        comm: the MPI communicator the mesh is distributed over.
        outputs: the outputs of the scene (``outputs.cell_maxima()``: stress and strain per cell).
        results: the Results of the last :meth:`solve` (None before it).
    """

    def __init__(self, scene: Scene, comm: Any = None, *, checked: bool = False):
        """Check the scene, mesh it and build its physics and outputs (``comm``: MPI.COMM_WORLD when None).

        ``checked``: the scene has passed :func:`check` already (``load_scene``), so it is not checked again.
        """
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_WORLD
        if not checked:
            check(scene)
        self.scene, self.comm = scene, comm
        self._clock = Clock()
        self.outputs = _build(scene, comm, self._clock)
        self.results: Results | None = None
        self._reported: list[Snapshot] = []
        self._solves = 0
        self._newton: NewtonSolver | None = None  # built at the first solve, kept for the next ones
        self._built = {key: float(c.value) for key, c in self.physics.parameters.items()}

    @property
    def physics(self) -> Physics:
        """The discrete problem: forms, unknowns, boundary conditions, the parameters' Constants."""
        return self.outputs.physics

    @property
    def mesh(self) -> Any:
        """The dolfinx mesh."""
        return self.physics.mesh

    @property
    def u(self) -> Any:
        """The displacement (a dolfinx Function, m): the solved state after :meth:`solve`."""
        return self.physics.u

    def solve(self, out_dir: str | Path | None = None, on_report: OnReport | None = None, *,
              start: str = "rest") -> Results:
        """Follow the load ramp from rest; return the Results (and write ``out_dir/results.json``, if given).

        By default (``start="rest"``) every call starts from rest at the model's current values.
        ``start="previous"``: each reported force of a force-controlled pull is first tried from the
        previous solve's state at that force (a warm start: about half the Newton iterations of a later
        answer at nearby values; its numbers within the solver's tolerance of the answer from rest, not
        the same bits; the force-displacement curve then has the reported forces only; docs/api.md).
        Contact's multipliers and slip bounds are not carried over. The solved state is ``model.u`` and
        ``model.outputs`` once solve returns, and :meth:`reports` sets the state of each reported force.
        ``on_report(force_n, outputs)`` (on every rank, at each reported force) is deprecated: use
        :meth:`reports`. Raises SolveStopped after writing the converged part when the ramp cannot be
        completed (``model.results`` and :meth:`reports` have it).
        """
        if on_report is not None:
            warnings.warn("Model.solve's on_report is deprecated: after solve(), model.reports() sets the state of "
                          "each reported force on the model", DeprecationWarning, stacklevel=2)
        warm = self._previous_states(start)
        clock = self._clock if self._solves == 0 else Clock(meshing=self._clock.meshing, timings=Timings())
        self._solves += 1
        out = output_folder(out_dir, self.comm)
        self._at_rest()
        steps = LoadSteps(self.scene, self.outputs, out, clock, on_report)
        self.results, self._reported = steps.results, steps.snapshots
        try:
            _check_axial_support(self.scene)
            steps.open_fields()
            if self._newton is None:
                self._newton = NewtonSolver.of(self.physics, self.scene.solver, clock.timings)
            history = ramp(self.physics, self.scene, steps.converged, clock.timings, solver=self._newton, warm=warm)
            steps.close()
            signals.check(self.comm)  # a signal since the last step (on any rank): interrupted, not converged
        except BaseException as exc:
            steps.ended(exc)
            raise
        finally:
            if self._solves == 1 and self._newton is not None:  # a model solved once keeps no factorisation
                self._newton.release()
        steps.finished(history)
        return steps.results

    def close(self) -> None:
        """Free the Newton solver (its matrices, factorisation and PETSc options); a later solve builds it again."""
        if self._newton is not None:
            self._newton.destroy()
            self._newton = None

    def _previous_states(self, start: str) -> Callable[[float], Any] | None:
        """The warm start of ``solve(start=...)``: the last solve's state at a reported force, or None."""
        if start not in ("rest", "previous"):
            raise ValueError(f'Model.solve start must be "rest" or "previous", got {start!r}')
        if start == "previous" and (self.physics.control is not None or self.physics.dynamics is not None):
            raise ValueError('Model.solve start="previous" needs the quasi-static force ramp (loading.control = '
                             '"force", effects.inertia = false): it starts each reported force from the last answer')
        kept = {round(s.force_n, 9): s.state for s in self._reported} if start == "previous" else {}
        return (lambda force_n: kept.get(round(force_n, 9))) if kept else None

    def reports(self) -> Iterator[Report]:
        """Each reported force of the last solve in turn, with the model set to its solved state.

        ``for report in model.reports(): grids[report.force_n] = plots.field_grid(model.outputs)``: while
        a report is yielded, ``model.u``, ``model.outputs`` (``cell_maxima()``, ``evaluate()``: the same
        record again) and the physics are as they were when that report's outputs were evaluated, the
        last state of a stopped ramp included. When the loop ends or is left, the model is back at the
        state :meth:`solve` ended in. Setting a state needs no communication; what is computed at it
        usually does, so every rank runs the same loop.
        """
        for report in self._solved().at_forces:
            with self.at(report.force_n):
                yield report

    @contextmanager
    def at(self, force_n: float) -> Iterator[Report]:
        """``with model.at(4.0) as report:`` the model set to the state of that reported force, then back.

        Raises KeyError when the last solve reported no such force (``model.results.at_forces`` lists them).
        """
        results = self._solved()
        found = [i for i, r in enumerate(results.at_forces) if abs(r.force_n - force_n) <= 1e-12 * max(1.0, force_n)]
        if not found:
            raise KeyError(f"no reported force {force_n:g} N in the last solve (reported: "
                           f"{', '.join(f'{r.force_n:g}' for r in results.at_forces) or 'none'})")
        ended = Snapshot.take(self.physics, results.force_reached_n or 0.0)
        try:
            self._reported[found[-1]].restore(self.physics)
            yield results.at_forces[found[-1]]
        finally:
            ended.restore(self.physics)

    def _solved(self) -> Results:
        if self.results is None:
            raise RuntimeError("the model has not been solved yet: call model.solve() first")
        return self.results

    def _at_rest(self) -> None:
        """The state and loads of a freshly built physics: zero displacement, no pull, no weight."""
        physics = self.physics
        physics.state.x.array[:] = 0.0
        physics.sync()
        physics.traction.value = 0.0
        if physics.gravity_factor is not None:
            physics.gravity_factor.value = 0.0
        if physics.rigid_displacement is not None:
            physics.rigid_displacement.value = 0.0
        for law in slip_laws(physics):  # no contact pressure yet: no slip bound, no multiplier
            law.reset()
        if physics.control is not None:
            physics.control.set(0.0)

    def settable(self) -> list[str]:
        """The scene keys :meth:`set` can change on this model (no new mesh, no new form)."""
        return sorted(k for k in (*self.physics.parameters, *RAMP_KEYS) if self._why_not(k, 1.0) is None)

    def set(self, values: Mapping[str, Any]) -> Model:
        """Set dotted scene keys that need no new mesh and no new form; the next :meth:`solve` uses them.

        ``model.set({"materials.tissue_scale": 1.2, "loading.force_n": 2.0})``: the values are validated
        like a scene file's, then the Constants are set in place and ``model.scene`` is the new scene.
        A key that needs a new mesh or new forms is refused in one line (SceneError); build
        ``Model(model.scene.with_values({...}))`` for it. Returns the model.
        """
        scene = self.scene.with_values(dict(values))
        for key in values:
            why = self._why_not(key, scene.get(key))
            if why is not None:
                raise SceneError(f"scene key {key} cannot change on a built Model: {why}; build "
                                 f"Model(model.scene.with_values({{{key!r}: ...}})) instead")
        for key in values:
            if key in self.physics.parameters:
                self.physics.set_parameter(key, float(scene.get(key)))
        self.scene = scene
        return self

    def _why_not(self, key: str, new: Any) -> str | None:
        """Why ``key`` cannot be set on this model (None: it can)."""
        if key.startswith(("geometry.", "mesh.")):
            return "it changes the mesh"
        if key in RAMP_KEYS:
            return None
        if key not in self._built:
            return "it is not a Constant of the forms (it changes what is built)"
        if self._built[key] == 0.0 and float(new) != 0.0:
            return "its term was left out of the forms, built at 0"
        if self.physics.effects.contact and (key == "materials.tissue_scale"
                                                       or key.startswith("materials.hypodermis.")):
            return "the contact penalty's stiffness is built from it"
        return None
