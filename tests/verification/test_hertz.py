"""Axisymmetric Hertz contact (frictionless): force, contact radius and pressure against the closed form.

A rigid sphere pressed into a half-space (CONTACT.md; derivation and measures in
suture_fem/studies/verification/hertz.py), solved with the frictionless thread's penalty law on the
production weak form and Newton solver, on a P2 ladder of 16, 32, 64 cells each way (uniform over 2 a
next to the contact, 1/8 to 1/32 of a). Measured on this machine: F +0.57 %, +0.019 %, -0.009 %; the
pressure profile inside 0.9 a 2.0 %, 1.1 %, 0.15 % of p0 at its worst node; the contact's edge between
adjacent nodes around a.
"""

from __future__ import annotations

import pytest

from suture_fem.studies.verification.hertz import Hertz, hertz_solve

RUNGS = (16, 32, 64)


def test_the_closed_forms_are_contact_md_s_example():
    case = Hertz(radius=1.0, depth=0.01)
    assert case.contact_radius() == pytest.approx(0.1, rel=1e-12)
    assert case.force() == pytest.approx(1.4652e-3, rel=1e-4)
    assert case.peak_pressure() == pytest.approx(0.069958, rel=1e-4)


@pytest.fixture(scope="module")
def ladder():
    return {n: hertz_solve(Hertz(), n) for n in RUNGS}


def test_force_within_one_percent_and_converging(ladder):
    errors = [abs(run["force"] - 1.0) for run in ladder.values()]
    assert max(errors) < 0.01 and errors[-1] < 1e-3
    assert errors[0] > errors[1] > errors[2]


def test_contact_radius_lies_between_the_last_closed_and_the_first_open_node(ladder):
    widths = []
    for run in ladder.values():
        assert run["a_in"] <= 1.0 + 1e-9 <= run["a_out"] + 1e-9
        assert run["a_out"] - run["a_in"] == pytest.approx(run["h"] / 2, rel=1e-9)  # adjacent P2 nodes
        widths.append(run["a_out"] - run["a_in"])
    assert widths[0] > widths[1] > widths[2]


def test_pressure_profile_converges_to_hertz(ladder):
    errors = [run["pressure"] for run in ladder.values()]
    assert errors[0] > errors[1] > errors[2] and errors[-1] < 0.01
