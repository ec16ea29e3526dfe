"""The stepping's leap: where a ramp with contact would stop, one step to the next milestone (solve/stepping.py).

The decision alone, on a stepping object with a stand-in path (no mesh, no solve): the step it sets,
the once-per-load and per-ramp limits, and no leap without contact. The runs it carries are in
docs/contact.md ("The leap").
"""

from __future__ import annotations

from types import SimpleNamespace

from suture_fem.outputs.results import Results, SolverRecord
from suture_fem.solve.records import RampResult
from suture_fem.solve.stepping import LEAPS
from suture_fem.solve.stepping import _Stepper as Stepper

CONTACT, NO_CONTACT = SimpleNamespace(contact=True), SimpleNamespace(contact=False)


def _stepping(s: float) -> Stepper:
    stepping = object.__new__(Stepper)  # the decision needs only these attributes
    stepping.path = SimpleNamespace(targets=[0.25, 0.5, 0.75, 1.0], end=1.0, describe=lambda v: f"s = {v:g}")
    stepping.result, stepping.s, stepping.eps = RampResult(), s, 1e-12
    stepping.leapt_from, stepping.cuts_here, stepping.step = None, 6, 1e-4
    return stepping


def test_a_leap_goes_to_the_next_milestone_once_per_load():
    stepping = _stepping(0.3)
    assert stepping._leap(0.3001, CONTACT)
    assert stepping.step == 0.5 - 0.3 and stepping.cuts_here == 0 and stepping.result.leaps == 1
    assert not stepping._leap(0.3001, CONTACT)  # the leap from this load failed too: stop
    stepping.s = 0.5  # a milestone reached: the next one is the target
    assert stepping._leap(0.5001, CONTACT) and stepping.step == 0.75 - 0.5


def test_no_leap_without_contact_nor_past_the_ramps_limit():
    assert not _stepping(0.3)._leap(0.3001, NO_CONTACT)
    assert not _stepping(0.3)._leap(0.3001, None)
    stepping = _stepping(0.3)
    stepping.result.leaps = LEAPS
    assert not stepping._leap(0.3001, CONTACT)


def test_results_json_names_the_leaps_only_when_taken():
    result = RampResult()
    assert "leaps" not in SolverRecord.from_history(result).as_dict()
    result.leaps = 2
    record = SolverRecord.from_history(result)
    assert record.as_dict()["leaps"] == 2
    minimal = {"effects": {}, "scene": {}, "status": "stopped", "force_displacement": []}
    assert Results.from_dict({**minimal, **record.as_dict()}).solver == record  # read back, with and without
    result.leaps = 0
    assert Results.from_dict({**minimal, **SolverRecord.from_history(result).as_dict()}).solver.leaps == 0
