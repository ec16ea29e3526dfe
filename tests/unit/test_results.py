"""The typed results: what each load-step event adds to the JSON form, and the read-only mapping view."""

from __future__ import annotations

import json
from types import SimpleNamespace

from mpi4py import MPI

from suture_fem.outputs.report import Peak
from suture_fem.outputs.results import Diagnosis, Results
from suture_fem.support.errors import SolveStopped


def running() -> Results:
    return Results(run={"dofs": 12, "applied_force_n": 1.0}, effects={"elastic": True}, scene={"loading": {}})


def history() -> SimpleNamespace:
    return SimpleNamespace(steps=[1, 2], newton_iterations=9, cutbacks=1, linear_solver="mumps", fallbacks=[],
                           domain_rejections=0, inertia_shifts=0, line_search_switches=0, residual_floor_n=1e-12,
                           floor_above_atol=0)


def test_a_report_repeats_its_entries_at_top_level_but_force_n():
    res = running()
    res.step(0.5, 0.1)
    res.report(0.5, {"force_n": 0.5, "usum_mm": 1.0, "regions": {}})
    res.step(1.0, 0.3)
    res.report(1.0, {"force_n": 1.0, "usum_mm": 2.0, "regions": {}})
    d = res.to_dict()
    assert d["status"] == "running" and d["dofs"] == 12
    assert d["force_displacement"] == [[0.0, 0.0], [0.5, 0.1], [1.0, 0.3]]
    assert d["usum_mm"] == 2.0 and d["force_reached_n"] == 1.0 and "force_n" not in d
    assert [r["force_n"] for r in d["at_forces"]] == [0.5, 1.0]
    assert "time_history" not in d and "diagnosis" not in d and "wall_time_s" not in d and "load_steps" not in d


def test_the_mapping_view_reads_like_the_json_form():
    res = running()
    res.step(1.0, 0.3, time_s=0.02)
    res.report(1.0, {"force_n": 1.0, "usum_mm": 2.0})
    res.write(None, MPI.COMM_SELF, 1.5, {"meshing": 0.1})
    assert dict(res) == res.to_dict() and {**res} == res.to_dict()
    assert res["usum_mm"] == 2.0 and "usum_mm" in res and res.get("seqv_pa") is None
    assert res["time_history"] == [[0.02, 1.0, 0.3]] and res["wall_time_s"] == 1.5
    json.dumps(res.to_dict())


def test_a_finished_ramp_keeps_the_solver_bookkeeping():
    res = running()
    res.finish(history())
    d = res.to_dict()
    assert d["status"] == "converged" and d["load_steps"] == 2 and d["newton_iterations"] == 9
    assert d["linear_solver_fallbacks"] == [] and d["solves_at_residual_floor"] == 0


def test_a_stop_is_diagnosed_and_asks_for_the_last_converged_state():
    res = running()
    res.step(0.5, 0.1)
    res.report(0.5, {"force_n": 0.5})
    stop = SolveStopped.with_history(history(), cause="cutbacks", load_reached=0.7, attempted=0.8, detail="why")
    res.stop(stop)
    assert res.needs_report(0.7) and not res.needs_report(0.5) and not running().needs_report(0.0)
    d = res.to_dict()
    assert d["status"] == "stopped" and d["load_steps"] == 2
    assert d["diagnosis"] == {"cause": "cutbacks", "load_reached_n": 0.7, "attempted_n": 0.8, "detail": "why"}
    assert res.diagnosis == Diagnosis("cutbacks", 0.7, 0.8, "why")


def test_the_typed_view_reads_the_same_values_as_the_json_form():
    res = running()
    assert res.usum_mm is None and res.at_forces == []
    record = {"force_n": 1.0, "usum_mm": 2.0, "usum_mm_at_mm": [0.1, 9.5], "usum_mm_region": "suture",
              "seqv_pa": 3.0, "eptoeqv": 0.4, "thread_end_displacement_mm": 1.9,
              "regions": {"tissue": {"seqv_pa": 1.5, "seqv_pa_at_mm": [0.2, 4.0]}}}
    res.step(1.0, 1.9)
    res.report(1.0, record)
    (report,) = res.at_forces
    assert (report.force_n, report.usum_mm, report.seqv_pa, report.eptoeqv) == (1.0, 2.0, 3.0, 0.4)
    assert report == res.to_dict()["at_forces"][0] and report["regions"] is record["regions"]
    assert report.thread_end_displacement_mm == 1.9
    assert report.peak("usum_mm") == Peak(2.0, (0.1, 9.5), "suture")
    assert res.peak("seqv_pa", "tissue") == Peak(1.5, (0.2, 4.0), "tissue")
    assert (res.usum_mm, res.seqv_pa, res.eptoeqv) == (2.0, 3.0, 0.4) and res["usum_mm"] == res.usum_mm
    assert res.force_displacement == res.to_dict()["force_displacement"] == [[0.0, 0.0], [1.0, 1.9]]
    assert res.regions == record["regions"]


def test_results_json_reads_back_as_the_same_typed_results(tmp_path):
    res = running()
    res.step(0.5, 0.1)
    res.report(0.5, {"force_n": 0.5, "usum_mm": 1.0, "regions": {"tissue": {"seqv_pa": 3.0}}})
    res.step(1.0, 0.3, time_s=0.02)
    res.report(1.0, {"force_n": 1.0, "usum_mm": 2.0, "seqv_pa": 5.0, "regions": {}})
    res.stop(SolveStopped.with_history(history(), cause="cutbacks", load_reached=1.0, attempted=1.2, detail="why"))
    res.write(tmp_path / "results.json", MPI.COMM_SELF, 1.5, {"meshing": 0.1})
    back = Results.read(tmp_path / "results.json")
    assert back.to_dict() == json.loads((tmp_path / "results.json").read_text()) == res.to_dict()
    assert back.usum_mm == 2.0 and back.seqv_pa == 5.0 and back.run == {"dofs": 12, "applied_force_n": 1.0}
    assert [r.force_n for r in back.at_forces] == [0.5, 1.0] and back.at_forces[0].regions["tissue"]["seqv_pa"] == 3.0
    assert back.solver == res.solver and back.diagnosis == res.diagnosis and back.status == "stopped"
    assert back.force_displacement == [[0.0, 0.0], [0.5, 0.1], [1.0, 0.3]] and back.time_history == [[0.02, 1.0, 0.3]]
