"""The dimple's relief: the depth of the skin profile under a straightedge laid across a cone (the tilt removed)."""

from __future__ import annotations

import numpy as np
import pytest

from suture_fem.outputs.dimple import relief


def _profile(u):
    y = np.linspace(0.0, 20.0, 81)
    return [[float(a), float(b)] for a, b in zip(y, u(y))]


def test_a_tilt_has_no_relief_and_a_dip_on_it_is_measured_under_the_straightedge():
    tilt = lambda y: 0.8 - 0.06 * y  # noqa: E731
    assert relief(_profile(tilt), 5.0, 15.0)[0] == pytest.approx(0.0, abs=1e-12)
    dip = lambda y: tilt(y) - 0.1 * np.exp(-((y - 9.0) / 0.8) ** 2)  # noqa: E731
    depth, at = relief(_profile(dip), 5.0, 15.0)
    assert at == pytest.approx(9.0)
    assert depth == pytest.approx(0.1, rel=1e-3)  # the dip's own depth (its tails at the window's ends: < 1e-10)
    bump = lambda y: tilt(y) + 0.1 * np.exp(-((y - 9.0) / 0.8) ** 2)  # noqa: E731
    assert relief(_profile(bump), 5.0, 15.0)[0] == pytest.approx(0.0, abs=1e-10)  # nothing under the straightedge


def test_the_window_is_clipped_to_the_skin_and_needs_three_nodes():
    profile = _profile(lambda y: -0.05 * (y - 10.0) ** 2)  # a crest: the straightedge touches it at the ends only
    depth, at = relief(profile, -4.0, 24.0)  # clipped to [0, 20]
    assert depth == pytest.approx(0.0, abs=1e-12) and at in (0.0, 20.0)
    assert relief(profile, 10.0, 10.3) == (None, None)
    assert relief([], 0.0, 1.0) == (None, None)
