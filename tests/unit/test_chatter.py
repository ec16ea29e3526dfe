"""The cones' swapping nodes held within a Newton solve (physics/effects/chatter.py), on made-up pressures."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from suture_fem.physics.effects.chatter import ChatterHold


def _swapping(hold: ChatterHold) -> None:
    """Three iterates: pair 0 swaps open -> pressed -> open (two changes), pair 1 stays pressed, pair 2 opens once."""
    for trial in ([-1.0, 5.0, 2.0], [3.0, 5.0, -1.0], [-2.0, 4.0, -1.0]):
        hold.iterate(np.array(trial))


def test_a_node_that_swaps_twice_is_held_pressed_and_the_others_follow_the_law():
    hold = ChatterHold(MPI.COMM_SELF, 3, possible=True)
    hold.begin(first=True)
    _swapping(hold)
    assert hold.held.tolist() == [True, False, False]
    # held pressed whatever its trial pressure; the others read lambda - kappa phi > 0
    assert hold.closed(np.array([-2.0, 4.0, -1.0])).tolist() == [True, True, False]
    assert hold.closed(np.array([-2.0, -4.0, 1.0])).tolist() == [True, False, True]


def test_a_held_node_on_the_wrong_side_of_the_law_is_held_the_other_way_in_the_next_solve():
    hold = ChatterHold(MPI.COMM_SELF, 3, possible=True)
    hold.begin(first=True)
    _swapping(hold)
    assert hold.check(np.array([-0.5, 4.0, -1.0]), slack=1.0) == 0  # pulls by less than the slack: accepted
    assert hold.check(np.array([-2.0, 4.0, -1.0]), slack=1.0) == 1  # pulls by more: wrong
    hold.begin(first=False)  # the next solve of the same step
    assert hold.held.tolist() == [True, False, False] and hold.state.tolist() == [False, False, False]
    assert hold.closed(np.array([3.0, 4.0, -1.0])).tolist() == [False, True, False]  # held open
    hold.begin(first=True)  # a new step: nothing carried
    assert not hold.held.any()


def test_nothing_is_held_where_holding_does_not_apply():
    hold = ChatterHold(MPI.COMM_SELF, 3, possible=False)
    hold.begin(first=True)
    _swapping(hold)
    assert not hold.held.any()
    assert hold.closed(np.array([-2.0, 4.0, 1.0])).tolist() == [False, True, True]


def test_a_node_at_zero_pressure_to_round_off_does_not_swap():
    """Sign changes within the band (a tenth of the target's pressure) are not swaps: round-off holds no node."""
    hold = ChatterHold(MPI.COMM_SELF, 2, possible=True, slack=10.0)
    hold.begin(first=True)
    for trial in ([1e-9, 5.0], [-1e-9, -5.0], [0.5, 5.0], [-0.5, -5.0]):
        hold.iterate(np.array(trial))
    assert hold.held.tolist() == [False, True]
