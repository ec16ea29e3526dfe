"""Contact patch test: a uniform pressure through a flat frictionless interface is transmitted exactly.

A distorted-mesh cylinder on a rigid plane under a uniform top pressure (suture_fem/studies/verification/
patch.py): the frictionless penalty's contact pressure equals the applied pressure at every interface node,
at P1 and P2 (measured: 9e-16 and 5e-15 relative), and the base's total force equals P pi R^2.
"""

from __future__ import annotations

import pytest

from suture_fem.studies.verification.patch import patch_solve


@pytest.mark.parametrize("degree", [1, 2])
def test_uniform_pressure_is_transmitted_exactly(degree):
    run = patch_solve(6, degree)
    assert run["worst"] < 1e-9
    assert run["total"] == pytest.approx(1.0, rel=1e-9)
