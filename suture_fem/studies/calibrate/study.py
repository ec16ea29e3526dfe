"""The calibration's entry: fit, propagate to the fitted curve with its band, write json, report, picture."""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.scene import Scene
from suture_fem.studies.calibrate.data import EPTOEQV_CD, SEQV_CD, UNITS, USUM, Point
from suture_fem.studies.calibrate.fit import fit
from suture_fem.studies.calibrate.keys import FitKey
from suture_fem.studies.calibrate.model import Model
from suture_fem.studies.calibrate.report import markdown, picture
from suture_fem.support.errors import SceneError
from suture_fem.support.io import write_json, write_text
from suture_fem.support.parallel import on_root

log = logging.getLogger("suture_fem")

#: Forces (as fractions of each group's largest measured force) at which the fitted curve is drawn.
CURVE_FRACTIONS = tuple(np.linspace(0.1, 1.0, 10))


def check_scene(scene: Scene) -> None:
    """A calibration solves quasi-static ramps with direct sensitivities: inertia is refused (SceneError).

    The contact terms are in the sensitivities' Jacobian (:mod:`suture_fem.solve.jacobian`; a settled augmented
    Lagrangian's pressed nodes held on their cones). A Coulomb bound follows the contact pressure between Newton
    solves, which the frozen-bound Jacobian leaves out (1.3e-4 of the derivative for the thread, 3.3e-4 for the
    cones, one cone at 0.5 N); on reproduce's target the fit lands on the root of a derivative-free search for
    both (docs/contact.md), so Coulomb is accepted.
    """
    if scene.effects.inertia:
        raise SceneError("scene key effects.inertia = true: calibrate fits quasi-static ramps (set it false)")


def calibrate(scene: Scene, points: list[Point], keys: list[FitKey], comm: Any, out: Path | None = None,
              max_evaluations: int = 30, curve: bool = True, model: Any = None) -> dict[str, Any]:
    """Fit ``keys`` to ``points``; returns (and writes under ``out``) the calibration record.

    ``model`` replaces the finite element :class:`Model` (anything with its ``keys``, ``points``,
    ``predict``, ``history`` and ``cost``: a test's closed-form model).
    """
    check_scene(scene)
    t0 = time.perf_counter()
    model = model if model is not None else Model(scene, points, keys, comm)
    record = fit(model, max_evaluations)
    record["data"] = [p.__dict__ for p in points]
    record["evaluations"] = model.history
    if curve:
        record["curve"] = fitted_curve(model, record)
    record["cost"] = {**model.cost.as_dict(), "total_wall_time_s": round(time.perf_counter() - t0, 2)}
    record["scene_mesh"] = scene.as_dict()["mesh"]
    if out is not None:
        on_root(comm, "creating the output folder", Path(out).mkdir, parents=True, exist_ok=True)
        on_root(comm, "writing calibration.json", write_json, Path(out) / "calibration.json", record)
        on_root(comm, "writing calibration.md", write_text, Path(out) / "calibration.md", markdown(record))
        if curve:
            on_root(comm, "drawing calibration.png", picture, record, Path(out) / "calibration.png")
    return record


def fitted_curve(model: Model, record: dict[str, Any]) -> list[dict[str, Any]]:
    """The fitted model over each group's forces, with its linearised 95 % band (one ramp per group).

    The data's own quantity (the curve the data are compared with), USUM and the tissue's converged
    stress measures (the critical-distance averages :data:`SEQV_CD`, :data:`EPTOEQV_CD`; not when the
    scene's ``output.critical_distance_mm`` is 0), all propagated from the parameters' covariance through
    the sensitivities at the fitted values: half-width = q sqrt(g^T Cov g), g = dy/dtheta, q the normal
    97.5 % quantile.
    """
    theta = np.array([record["parameters"][k.key]["value"] for k in model.keys])
    cov = np.array(record["covariance"])
    from scipy import stats  # here, not at import: scipy costs every command 0.3 s of CPU

    quantile = stats.norm.ppf(0.975)
    stress = [SEQV_CD, EPTOEQV_CD] if model.scene.output.critical_distance_mm > 0 else []
    out = []
    for cones, idx in model.groups().items():
        f_max = max(model.points[i].force_n for i in idx)
        forces = sorted({round(f_max * a, 9) for a in CURVE_FRACTIONS} | {model.points[i].force_n for i in idx})
        quantities = list(dict.fromkeys([model.points[idx[0]].quantity, USUM, *stress]))
        for quantity, (y, J) in model.quantities_at(theta, cones, forces, quantities).items():
            half = quantile * np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, cov, J), 0.0))
            out.append({"cones": cones, "quantity": quantity, "unit": UNITS[quantity], "force_n": forces,
                        "model": y.tolist(), "band95": half.tolist(),
                        "sensitivity": [dict(zip((k.key for k in model.keys), row)) for row in J.tolist()]})
    return out
