"""The calibration's direct sensitivities with the cones' contact: the hand-assembled terms in the Jacobian.

du/dp = -A^-1 dR/dp needs A with the cones' contact terms (suture_fem/solve/jacobian.py, shared with Newton);
with the augmented Lagrangian's multipliers settled, the pressed nodes held on their cones. Checked against a
central difference of two converged solves (tissue_scale +- 1e-4) on one cone, P1, 0.5 N; and the
calibration's path (Newton's factorisation reused, or A assembled here) equals the one without a solver.

Measured (dUSUM/dtissue_scale, relative to the central difference): sliding 7e-9 (with the forms' Jacobian
only, as before: 0.16); frictionless 1.3e-7 (forms only: 4.7e-4; the multipliers frozen, not settled: 1.1e-4).
Each solve starts from rest: a solve warm-started from the last one's state (the calibration's) settles the
multipliers along another path and ends about 1 nm away (within the penetration target), 0.4 % of the
difference of two solves 1e-4 apart.
"""

from __future__ import annotations

import pytest
from mpi4py import MPI

from suture_fem.pipeline import load_scene
from suture_fem.studies.calibrate.data import THREAD_END, USUM
from suture_fem.studies.calibrate.model import Case, Cost

FORCE = 0.5
KEY = "materials.tissue_scale"
QUANTITIES = [THREAD_END, USUM]


def _case(interface: str) -> Case:
    scene = load_scene("paper", ["mesh.degree=1", "mesh.refinement=0", f"loading.force_n={FORCE}",
                                 "loading.report_forces_n=[]", "solver.petsc_options.snes_stol=1e-14",
                                 "geometry.cones=1", f'effects.cone_interface="{interface}"'])
    return Case(scene, MPI.COMM_WORLD, Cost())


def _check(interface: str, rtol: float) -> None:
    case = _case(interface)
    at = case.solve_many({KEY: 1.0}, [FORCE], QUANTITIES, [KEY])  # Newton's solver handed to the sensitivity
    _, alone, _ = case.sensitivity.at_state_many(QUANTITIES, [KEY], None)  # A assembled by the sensitivity
    h, sides = 1e-4, []
    for sign in (1, -1):
        case.states = None  # from rest, as the first: a warm start settles the multipliers along another path
        sides.append(case.solve_many({KEY: 1.0 + sign * h}, [FORCE], QUANTITIES, []))
    plus, minus = sides
    for q, quantity in enumerate(QUANTITIES):
        direct = at[quantity][1][0, 0]
        fd = (plus[quantity][0][0] - minus[quantity][0][0]) / (2 * h)
        assert alone[q][0] == pytest.approx(direct, rel=1e-8), quantity
        assert abs(direct - fd) <= rtol * abs(fd), (quantity, direct, fd)


def test_sliding_cones_sensitivity_equals_central_difference():
    _check("sliding", 1e-6)


@pytest.mark.long  # about 20 s CPU: the multipliers' fixed point in each of three ramps
def test_frictionless_cones_sensitivity_equals_central_difference():
    _check("frictionless", 1e-5)


@pytest.mark.parametrize("interface", ['effects.cone_interface="coulomb"', 'effects.thread_interface="coulomb"',
                                       'effects.cone_interface="frictionless"'])
def test_calibrate_takes_every_interface_model(interface):
    from suture_fem.studies.calibrate.study import check_scene
    from suture_fem.support.errors import SceneError

    assert check_scene(load_scene("paper", ["mesh.degree=1", interface])) is None
    with pytest.raises(SceneError, match="effects.inertia"):
        check_scene(load_scene("paper", ["mesh.degree=1", interface, "effects.inertia=true"]))
