"""The model side of a calibration: predictions at the measured forces and their sensitivities.

One :class:`Case` is one mesh (a cone count and the geometric values) with its physics built once;
every evaluation at new parameter values sets the parameters' Constants, starts from rest and
follows one load ramp that stops at every measured force (no form is compiled again). From the second
evaluation of a case on, each measured force is first tried straight from the previous evaluation's
state there, moved by its sensitivities: u(p) + du/dp (p' - p) (a warm start,
:func:`~suture_fem.solve.stepping.ramp`'s ``warm``); the usual steps take over where Newton fails from it. At each
measured force the prediction (the thread end's displacement, or USUM) is read, and its sensitivity to
every parameter that is a Constant of the forms is computed by the direct method
(:mod:`suture_fem.studies.calibrate.sensitivity`). A geometric key changes the mesh: its sensitivity
is a central finite difference over two remeshed solves (:class:`Model`).
"""

from __future__ import annotations

import logging
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from suture_fem.geometry import mesh as meshmod
from suture_fem.physics.effects.friction import slip_laws
from suture_fem.physics.problem import build_physics
from suture_fem.pipeline import with_values
from suture_fem.scene import Scene
from suture_fem.solve.stepping import ramp
from suture_fem.studies.calibrate.data import Point
from suture_fem.studies.calibrate.keys import FitKey
from suture_fem.studies.calibrate.sensitivity import Sensitivity

log = logging.getLogger("suture_fem")

#: Relative step of the central finite difference of a geometric key. Each side is a new mesh, whose
#: discretisation error differs from the other side's by a small amount unrelated to h; a 2 % step
#: keeps that noise well below the difference itself on the coarse meshes a calibration uses.
FD_STEP = 0.02
#: Meshes kept built (the current point and its finite-difference neighbours).
KEEP_CASES = 6


@dataclass
class Cost:
    """What the calibration's evaluations cost: ramps, Newton iterations, time (no factorisations of its own)."""

    evaluations: int = 0
    ramps: int = 0
    meshes: int = 0
    newton_iterations: int = 0
    load_steps: int = 0
    wall_time_s: float = 0.0
    cpu_time_s: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """The ``cost`` record of calibration.json."""
        return {k: (round(v, 3) if isinstance(v, float) else v) for k, v in self.__dict__.items()}


class Case:
    """One mesh with its physics built once; solved from rest at any values of the Constant parameters."""

    def __init__(self, scene: Scene, comm: Any, cost: Cost):
        """Mesh and physics of ``scene`` (its cone count and geometry)."""
        self.scene, self.comm, self.cost = scene, comm, cost
        tagged = meshmod.scene_mesh(comm, scene)
        self.physics = build_physics(tagged, scene)
        self.sensitivity = Sensitivity(self.physics, scene.output)
        self.states: tuple[dict[str, float], list[str], dict[float, Any]] | None = None  # for warm starts
        cost.meshes += 1

    def _warm_start(self, values: dict[str, float]) -> Any:
        """Start states at the measured forces from the last evaluation and its du/dp (None when not possible).

        Possible when the last evaluation set the same keys and every key that changed had its du/dp.
        """
        if self.states is None:
            return None
        old, keys, states = self.states
        if set(old) != set(values) or any(values[k] != old[k] and k not in keys for k in values):
            return None
        steps = [(j, values[k] - old[k]) for j, k in enumerate(keys) if k in values and values[k] != old[k]]

        def start(force_n: float) -> Any:
            found = states.get(round(force_n, 9))
            if found is None:
                return None
            u, changes = found
            u = u.copy()
            for j, step in steps:
                u += step * changes[j]
            return u

        return start

    def solve(self, values: dict[str, float], forces: list[float], quantity: str,
              direct: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """Predictions at ``forces`` and their derivatives with respect to the ``direct`` keys.

        Returns (y, dy) with y[i] at forces[i] and dy[i, j] = dy_i / d(direct[j]).
        """
        return self.solve_many(values, forces, [quantity], direct)[quantity]

    def solve_many(self, values: dict[str, float], forces: list[float], quantities: list[str],
                   direct: list[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """:meth:`solve` of several quantities along one ramp: quantity -> (y, dy)."""
        physics = self.physics
        for key, value in values.items():
            physics.set_parameter(key, value)
        physics.state.x.array[:] = 0.0
        physics.sync()
        if physics.rigid_displacement is not None:
            physics.rigid_displacement.value = 0.0
        for law in slip_laws(physics):  # from rest: no contact pressure, no slip bound, no multiplier
            law.reset()
        scene = with_values(self.scene, {"loading.force_n": max(forces), "loading.report_forces_n": sorted(forces)})
        at: dict[float, tuple[list[float], list[np.ndarray]]] = {}

        states: dict[float, Any] = {}

        def on_converged(force_n: float, report: bool, time_s: float | None = None, solver: Any = None) -> None:
            if report:  # the Newton solver's own factorisation gives du/dp (none is added)
                values, derivatives, changes = self.sensitivity.at_state_many(quantities, direct, solver)
                at[round(force_n, 9)] = (values, derivatives)
                states[round(force_n, 9)] = (physics.state.x.array.copy(), changes)

        warm = self._warm_start(values)
        self.states = None  # a ramp that stops half-way leaves no states to start from
        result = ramp(physics, scene, on_converged, with_solver=True, warm=warm)
        self.states = (dict(values), list(direct), states)
        self.cost.ramps += 1
        self.cost.newton_iterations += result.newton_iterations
        self.cost.load_steps += len(result.steps)
        out = {}
        for q, quantity in enumerate(quantities):
            y = np.array([at[round(f, 9)][0][q] for f in forces])
            dy = np.array([at[round(f, 9)][1][q] for f in forces]).reshape(len(forces), len(direct))
            out[quantity] = (y, dy)
        return out


@dataclass
class Model:
    """Predictions of every data point and their Jacobian with respect to the fitted keys.

    Attributes:
        scene: the base scene; points: the data; keys: the fitted keys; comm: the communicator.
    """

    scene: Scene
    points: list[Point]
    keys: list[FitKey]
    comm: Any
    cost: Cost = field(default_factory=Cost)
    history: list[dict[str, Any]] = field(default_factory=list)
    _cases: OrderedDict = field(default_factory=OrderedDict)

    def groups(self) -> dict[int | None, list[int]]:
        """Data indices by cone count (None: the scene's own), each group solved by one ramp."""
        out: dict[int | None, list[int]] = {}
        for i, p in enumerate(self.points):
            out.setdefault(p.cones, []).append(i)
        return out

    def _case(self, cones: int | None, geometric: dict[str, float]) -> Case:
        values = {**geometric, **({"geometry.cones": cones} if cones is not None else {}), "output.fields": False}
        ident = tuple(sorted((k, float(v)) for k, v in values.items()))
        if ident not in self._cases:
            self._cases[ident] = Case(with_values(self.scene, values), self.comm, self.cost)
            while len(self._cases) > KEEP_CASES:
                self._cases.popitem(last=False)
        self._cases.move_to_end(ident)
        return self._cases[ident]

    def predict(self, theta: np.ndarray, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """(y, J): every prediction at parameter values ``theta`` and dy/dtheta (zeros when not asked)."""
        t0, c0 = time.perf_counter(), time.process_time()
        values = dict(zip((k.key for k in self.keys), map(float, theta)))
        direct = [k.key for k in self.keys if not k.geometric] if jacobian else []
        geometric = {k.key: values[k.key] for k in self.keys if k.geometric}
        constants = {k: v for k, v in values.items() if k not in geometric}
        y = np.zeros(len(self.points))
        J = np.zeros((len(self.points), len(self.keys)))
        for cones, idx in self.groups().items():
            forces = [self.points[i].force_n for i in idx]
            quantity = self.points[idx[0]].quantity
            yc, dyc = self._case(cones, geometric).solve(constants, forces, quantity, direct)
            y[idx] = yc
            for j, key in enumerate(self.keys):
                if key.key in direct:
                    J[idx, j] = dyc[:, direct.index(key.key)]
                elif jacobian:
                    J[idx, j] = self._difference(cones, geometric, constants, key.key, forces, quantity)
        self.cost.evaluations += 1
        self.cost.wall_time_s += time.perf_counter() - t0
        self.cost.cpu_time_s += time.process_time() - c0
        self.history.append({"values": values, "predictions_mm": y.tolist()})
        log.info("calibration: %s -> %s mm", ", ".join(f"{k} = {v:.6g}" for k, v in values.items()),
                 ", ".join(f"{v:.4f}" for v in y))
        return y, J

    def quantities_at(self, theta: np.ndarray, cones: int | None, forces: list[float],
                      quantities: list[str]) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Several quantities of one cone count at ``forces``, and their Jacobians: quantity -> (y, J).

        One ramp (three for each geometric key: its central difference) for all of them: the
        predictions at the fitted parameters (:func:`~suture_fem.studies.calibrate.study.fitted_curve`).
        """
        values = dict(zip((k.key for k in self.keys), map(float, theta)))
        direct = [k.key for k in self.keys if not k.geometric]
        geometric = {k.key: values[k.key] for k in self.keys if k.geometric}
        constants = {k: v for k, v in values.items() if k not in geometric}
        solved = self._case(cones, geometric).solve_many(constants, forces, quantities, direct)
        out = {}
        for quantity, (y, dy) in solved.items():
            J = np.zeros((len(forces), len(self.keys)))
            for j, key in enumerate(self.keys):
                if key.key in direct:
                    J[:, j] = dy[:, direct.index(key.key)]
            out[quantity] = (y, J)
        for j, key in enumerate(self.keys):
            if key.geometric:
                diffs = self._difference(cones, geometric, constants, key.key, forces, quantities)
                for quantity in quantities:
                    out[quantity][1][:, j] = diffs[quantity]
        return out

    def _difference(self, cones: int | None, geometric: dict[str, float], constants: dict[str, float], key: str,
                    forces: list[float], quantity: str | list[str]) -> Any:
        """Central finite difference of the predictions with respect to a geometric key (two remeshed solves).

        One quantity: its array; a list: quantity -> array.
        """
        h = FD_STEP * geometric[key]
        names = [quantity] if isinstance(quantity, str) else quantity
        sides = []
        for sign in (1, -1):
            case = self._case(cones, {**geometric, key: geometric[key] + sign * h})
            sides.append(case.solve_many(constants, forces, names, []))
        diffs = {q: (sides[0][q][0] - sides[1][q][0]) / (2 * h) for q in names}
        return diffs[quantity] if isinstance(quantity, str) else diffs
