"""A rigid plug in an elastic tube with Coulomb friction: contact pressure, stick stiffness, full-slip force.

CONTACT.md's closed forms (derivation: suture_fem/studies/verification/plug.py; docs/contact.md), at small
strain (P / G = 1e-3), on a graded P2 mesh ladder (4, 8, 16 cells across the tube), solved with the
package's penalty contact and Coulomb terms (the plug as a rigid surface):

* the contact pressure q: within 1 % on average at every rung, at every node from the second, and the
  error falls with the mesh;
* the stick stiffness K = 2 pi G H / ln(b / a), with a large coefficient (mu = 300: stuck everywhere)
  at half the slip displacement: within 1 % (the regularised slip's compliance, s / d, is 0.1 %);
* the full-slip force F = 2 pi a H mu q (mu = 0.3) at three times the slip displacement: within 1 %.
"""

from __future__ import annotations

import pytest

from suture_fem.studies.verification.plug import PlugInTube, plug_solve

SLIDING = PlugInTube(pressure=1e-3)  # CONTACT.md's example scaled to small strain; mu = 0.3
STUCK = PlugInTube(pressure=1e-3, mu=300.0)
SLIP_D = SLIDING.slip_force() / SLIDING.stick_stiffness()  # the plug's displacement where it starts to slide
RUNGS = (4, 8, 16)


def test_the_closed_forms_are_contact_md_s_example():
    case = PlugInTube()
    assert case.contact_pressure() == pytest.approx(0.139442, rel=1e-5)
    assert case.stick_stiffness() == pytest.approx(2.72875, rel=1e-5)
    assert case.slip_force() == pytest.approx(0.262842, rel=1e-5)
    assert case.slip_force() / case.stick_stiffness() == pytest.approx(0.096323, rel=1e-4)


@pytest.fixture(scope="module")
def ladder():
    return {n: (plug_solve(STUCK, 0.5 * SLIP_D, n, slip=SLIP_D), plug_solve(SLIDING, 3 * SLIP_D, n, slip=0.1 * SLIP_D))
            for n in RUNGS}


def test_the_contact_pressure_converges_to_lames(ladder):
    errors = []
    for n, (stuck, sliding) in ladder.items():
        for run in (stuck, sliding):
            assert abs(run["q"] - 1.0) < 0.01
            if n > RUNGS[0]:
                assert run["q_worst"] < 0.01
        errors.append(abs(stuck["q"] - 1.0))
    assert errors[0] > errors[1] > errors[2]


def test_a_stuck_plug_has_the_anti_plane_stiffness(ladder):
    for stuck, _ in ladder.values():
        assert abs(stuck["force"] - 1.0) < 0.01  # force over K d


def test_a_sliding_plug_carries_the_full_slip_force(ladder):
    for _, sliding in ladder.values():
        assert abs(sliding["force"] - 1.0) < 0.01  # force over 2 pi a H mu q
