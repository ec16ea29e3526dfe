"""The interface output's geometry helpers, without a solve: arc length along a cone, the gap map's ranges."""

from __future__ import annotations

import math

import numpy as np
import pytest

from suture_fem.outputs.cone_gaps import intervals
from suture_fem.outputs.interface import _arc_coordinate, part_names


def test_arc_length_follows_a_filleted_outline_from_its_first_point():
    # a unit square's outline with a quarter-circle fillet of radius 0.25 at (1, 1)
    r = 0.25
    outline = [("line", ((0.0, 0.0), (1.0, 0.0))), ("line", ((1.0, 0.0), (1.0, 1.0 - r))),
               ("arc", ((1.0, 1.0 - r), (1.0 - r, 1.0 - r), (1.0 - r, 1.0))), ("line", ((1.0 - r, 1.0), (0.0, 1.0)))]
    mid_arc = (1.0 - r + r * math.cos(math.pi / 4), 1.0 - r + r * math.sin(math.pi / 4))
    points = np.array([(0.0, 0.0), (0.5, 0.0), (1.0, 0.0), (1.0, 0.5), mid_arc, (0.5, 1.0), (0.0, 1.0)])
    s = _arc_coordinate(points, outline)
    arc = math.pi / 2 * r
    expected = [0.0, 0.5, 1.0, 1.5, 1.0 + (1.0 - r) + arc / 2, 1.0 + (1.0 - r) + arc + (0.5 - r), 2 * (1 - r) + 1 + arc]
    assert s == pytest.approx(expected, abs=1e-12)
    # a corner shared by two segments keeps the earlier arc length
    assert _arc_coordinate(np.array([(1.0, 0.0)]), outline)[0] == pytest.approx(1.0)


def test_the_gap_map_lists_each_run_of_open_nodes_once():
    z = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    assert intervals(z, np.array([0, 1, 1, 0, 1, 0, 1], dtype=bool)) == [[1.0, 2.0], [4.0, 4.0], [6.0, 6.0]]
    assert intervals(z, np.zeros(7, dtype=bool)) == []
    assert intervals(z, np.ones(7, dtype=bool)) == [[0.0, 6.0]]


def test_parts_are_named_from_the_far_end():
    assert part_names(0) == ["thread"]
    assert part_names(3) == ["cone_1", "cone_2", "cone_3", "thread"]
