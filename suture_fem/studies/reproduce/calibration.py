"""The calibration: ONE parameter calibrated on ONE paper value, then every other value predicted.

The honest protocol of MODEL.md: every dimension the paper leaves open is fixed first from public data
(``suture_fem/scene/defaults.toml`` names each source); then ONE parameter is calibrated against ONE
value, USUM = 4.0 mm for 4 cones at 1 N (:data:`~suture_fem.studies.paper.TARGET`); every
other value of the paper is a prediction.

The calibration is ``suture-fem calibrate``'s (:mod:`suture_fem.studies.calibrate`): the bounded least
squares fit of one key to the one value, with its sensitivity by the direct method (a Constant of the
forms) or a central finite difference (a geometric key). One value and one parameter determine the
parameter exactly, so its 95 % interval comes from the paper's printed precision (4.0 mm: 0.1 mm, a
rounding error of +-0.05 mm) propagated through the sensitivity.

:data:`DEFAULT` is the tissue's global stiffness (``materials.tissue_scale``), :data:`CANDIDATES` the
three global compliance parameters the seven USUM values cannot tell apart (docs/reproduction.md).
The earlier search over the tissue length (an Illinois regula falsi on both margins) is gone: no
tissue length reaches 4.0 mm (1 mm: 2.69 mm, 30 mm: 2.03 mm), and the least squares fit does the
same job for any key, with an interval (``--calibrate geometry.margin_far_mm`` still tries one margin).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from suture_fem.scene import Scene
from suture_fem.studies.calibrate.data import USUM, Point, resolution
from suture_fem.studies.calibrate.keys import parse_fit
from suture_fem.studies.calibrate.study import calibrate as fit_study
from suture_fem.studies.paper import TARGET

log = logging.getLogger("suture_fem")

#: The parameter ``reproduce`` calibrates unless told otherwise.
DEFAULT = "materials.tissue_scale"
#: Its calibrated value in docs/reproduction.md, where the calibrated scene's mesh errors and the stress
#: ladders (:mod:`~suture_fem.studies.reproduce.stress_errors`) were measured.
MEASURED_SCALE = 0.3112
#: Three parameters that each scale the tissue's global compliance: the tissue's stiffness, the clamped
#: outer radius (the hypodermis thickness moves the clamped outer surface: radius = hypodermis + dermis
#: + epidermis), the force.
CANDIDATES = ("materials.tissue_scale", "geometry.hypodermis_mm", "loading.force_scale")
#: ``--calibrate none``: nothing calibrated, every value a prediction.
NONE = "none"


def target_point() -> Any:
    """The calibration target as a calibrate data point: USUM 4.0 mm (printed to 0.1 mm), 4 cones, 1 N."""
    return Point(TARGET.force_n, TARGET.value, None, resolution(TARGET.printed.split()[0]), USUM, TARGET.cones,
                 f"{TARGET.source}, {TARGET.cones} cones, {TARGET.force_n:g} N")


def parse_key(text: str, scene: Scene) -> Any:
    """``KEY[=LOW:HIGH]`` as a calibrate FitKey, or None for ``none`` (SceneError: one line, exit 2)."""
    if text.strip().lower() == NONE:
        return None
    return parse_fit(text, scene)


def calibrate(scene: Scene, comm: Any, key: Any, out: Path | None = None, max_evaluations: int = 20,
              model: Any = None) -> dict[str, Any]:
    """Fit ``key`` (a FitKey) to USUM = 4.0 mm at 4 cones, 1 N; returns the calibration record.

    Status "calibrated" when the fitted model reproduces the target within half its printed precision
    (0.05 mm) with the parameter inside its bounds; "unreachable" otherwise (the fit sits at a bound:
    no value in the bounds reaches 4.0 mm), and then nothing is moved. ``out`` receives calibrate's
    calibration.json and calibration.md; ``model`` replaces the finite element model (tests).
    """
    point = target_point()
    rec = fit_study(scene, [point], [key], comm, out, max_evaluations=max_evaluations, curve=False, model=model)
    p = rec["parameters"][key.key]
    usum = rec["predictions_mm"][0]
    reached = abs(usum - point.value_mm) <= point.resolution_mm / 2 and not p["at_bound"]
    status = "calibrated" if reached else "unreachable"
    if not reached:
        log.warning("calibration: no value of %s in [%g, %g] reaches USUM %g mm at %d cones, %g N (closest %.4f mm "
                    "at %.6g); nothing is moved", key.key, key.lo, key.hi, point.value_mm, point.cones,
                    point.force_n, usum, p["value"])
    return {
        "status": status,
        "key": key.key,
        "value": p["value"],
        "ci95": p["ci95"],
        "sd": p["sd"],
        "bounds": p["bounds"],
        "start": p["start"],
        "sensitivity": p["sensitivity"],
        "uncertainty_from": rec["uncertainty_from"],
        "target": {"source": TARGET.source, "cones": TARGET.cones, "force_n": TARGET.force_n,
                   "usum_mm": TARGET.value, "printed": TARGET.printed},
        "usum_mm": usum,
        "rel_error": (usum - TARGET.value) / TARGET.value,
        "dusum_dvalue_mm": rec["sensitivities_mm"][0][0],
        "fit": {"status": rec["status"], "message": rec["message"]},
        "evaluations": rec["evaluations"],
        "cost": rec["cost"],
        "mesh": scene.as_dict()["mesh"],
    }


def not_calibrated(scene: Scene) -> dict[str, Any]:
    """The record of ``--calibrate none``: nothing calibrated, every value a prediction."""
    return {"status": "not calibrated", "key": None,
            "target": {"source": TARGET.source, "cones": TARGET.cones, "force_n": TARGET.force_n,
                       "usum_mm": TARGET.value, "printed": TARGET.printed}, "mesh": scene.as_dict()["mesh"]}
