"""The Model: built once, solved again at new Constant values, the same numbers as a model built at them.

One cone, degree 1, the coarsest mesh (the forms of tests/integration/test_run.py: nothing new to compile).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from suture_fem import Model, Results, Scene, SceneError
from suture_fem.pipeline import run_scene

BASE = Scene.builtin("paper").with_values({"mesh.degree": 1, "mesh.refinement": 0, "geometry.cones": 1,
                                           "loading.force_n": 1.0, "loading.report_forces_n": [0.5]})
#: Every kind of key set() changes: a tissue constant, the suture's, both scales, the ramp's peak force.
CHANGED = {"materials.dermis.c10": 5000.0, "materials.suture.young": 1.2e9, "materials.tissue_scale": 1.3,
           "loading.force_scale": 0.9, "loading.force_n": 0.8}
#: What a second solve may differ in: the times and the process that wrote it.
NOT_COMPARED = {"wall_time_s", "timings_s", "process"}


def close(a, b, path="", rel=1e-10):
    """Every number of two results.json forms within ``rel`` (relative to the larger, or absolute below 1e-300)."""
    if isinstance(a, dict):
        assert set(a) - NOT_COMPARED == set(b) - NOT_COMPARED, path
        for k in set(a) - NOT_COMPARED:
            close(a[k], b[k], f"{path}.{k}", rel)
    elif isinstance(a, list):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            close(x, y, f"{path}[{i}]", rel)
    elif isinstance(a, float) and not isinstance(b, bool):
        assert abs(a - b) <= rel * max(abs(a), abs(b), 1e-300), (path, a, b)
    else:
        assert a == b, (path, a, b)


@pytest.fixture(scope="module")
def model():
    return Model(BASE)


@pytest.fixture(scope="module")
def first(model):
    return model.solve().to_dict()


def test_a_model_solves_as_run_scene_does_and_keeps_its_state(model, first, tmp_path):
    close(first, run_scene(BASE, tmp_path, model.comm).to_dict())
    written = json.loads((tmp_path / "results.json").read_text())
    assert Results.read(tmp_path / "results.json").to_dict() == written  # read back, typed again
    assert first["status"] == "converged" and [r["force_n"] for r in first["at_forces"]] == [0.5, 1.0]
    assert model.results.usum_mm == first["usum_mm"] and model.results.at_forces[-1].force_n == 1.0
    # the solved state stays reachable: USUM is the largest nodal |u| (mm)
    u = model.u.x.array.reshape(-1, 2)
    assert math.sqrt(np.max(np.sum(u**2, axis=1))) * 1e3 == pytest.approx(first["usum_mm"], rel=1e-12)
    assert model.mesh is model.physics.mesh and model.outputs.physics is model.physics


def test_reports_set_each_reported_state_again_and_end_at_the_solved_one(model, first):
    solved = model.u.x.array.copy()
    seen = []
    for report in model.reports():  # the outputs of the state set again: the record, bit for bit
        close(model.outputs.evaluate(), dict(report.record), rel=0.0)
        seen.append(report.force_n)
    assert seen == [0.5, 1.0] and np.array_equal(model.u.x.array, solved)
    with model.at(0.5) as report:
        u = model.u.x.array.reshape(-1, 2)
        assert math.sqrt(np.max(np.sum(u**2, axis=1))) * 1e3 == pytest.approx(report.usum_mm, rel=1e-12)
        assert report.usum_mm < first["usum_mm"]
    assert np.array_equal(model.u.x.array, solved)
    with pytest.raises(KeyError, match="reported: 0.5, 1"), model.at(0.7):
        pass


def test_on_report_still_works_with_a_deprecation_warning(model, first):
    called = []
    with pytest.warns(DeprecationWarning, match="model.reports"):
        again = model.solve(on_report=lambda f, outputs: called.append((f, outputs is model.outputs)))
    assert called == [(0.5, True), (1.0, True)]
    close(again.to_dict(), first)


def test_a_second_solve_after_set_is_a_fresh_model_at_those_values(model, first):
    settable = model.settable()
    assert set(CHANGED) <= set(settable) and not any(k.startswith(("geometry.", "mesh.")) for k in settable)
    second = model.set(CHANGED).solve().to_dict()
    fresh = Model(BASE.with_values(CHANGED)).solve().to_dict()
    close(second, fresh, rel=0.0)  # the kept Newton solver (its factorisation's analysis too): the same bits
    assert second["scene"] == BASE.with_values(CHANGED).as_dict()
    assert abs(second["usum_mm"] - first["usum_mm"]) > 1e-3 * first["usum_mm"]  # the values did change
    model.set({k: BASE.get(k) for k in CHANGED})
    close(model.solve().to_dict(), first, rel=0.0)  # and back


@pytest.mark.parametrize("values, words", [
    ({"geometry.cones": 2}, ["geometry.cones", "changes the mesh", "with_values"]),
    ({"mesh.degree": 2}, ["mesh.degree", "changes the mesh"]),
    ({"effects.gravity": True}, ["effects.gravity", "not a Constant"]),
    ({"materials.hypodermis.c30": 10.0}, ["materials.hypodermis.c30", "not a Constant"]),
    ({"materials.tissue_scale": 2.0, "geometry.cones": 2}, ["geometry.cones"]),
    ({"loading.force_n": -1.0}, ["loading.force_n", ">= 1e-06"]),
])
def test_a_key_that_needs_a_new_mesh_or_new_forms_is_refused_in_one_line(model, values, words):
    before = model.scene
    with pytest.raises(SceneError) as err:
        model.set(values)
    assert "\n" not in str(err.value) and all(w in str(err.value) for w in words), str(err.value)
    assert model.scene is before and float(model.physics.parameters["materials.tissue_scale"].value) == 1.0


def test_a_warm_start_from_the_previous_answer_takes_fewer_iterations_to_the_same_answer(model, first):
    """``solve(start="previous")``: each reported force first tried from the last solve's state there."""
    model.solve()  # the previous answer: at the base values
    cold_fresh = Model(BASE.with_values({"materials.tissue_scale": 1.2})).solve().to_dict()
    warm = model.set({"materials.tissue_scale": 1.2}).solve(start="previous").to_dict()
    assert warm["status"] == "converged" and warm["newton_iterations"] < cold_fresh["newton_iterations"]
    assert [p[0] for p in warm["force_displacement"]] == [0.0, 0.5, 1.0]  # straight to the reported forces
    for a, b in zip(warm["at_forces"], cold_fresh["at_forces"]):  # the same state to the solver's tolerance
        for key in ("usum_mm", "thread_end_displacement_mm", "strain_energy_j", "seqv_cd_pa", "eptoeqv_cd"):
            assert a[key] == pytest.approx(b[key], rel=1e-9), key
    with pytest.raises(ValueError, match='start must be "rest" or "previous"'):
        model.solve(start="warm")
    model.set({"materials.tissue_scale": 1.0})
    close(model.solve().to_dict(), first, rel=0.0)  # from rest again by default: the same bits as before


def test_a_closed_or_dropped_model_leaves_no_petsc_options_behind():
    # Debian 12's PETSc holds 512 options: the test suite's in-process runs once filled it (11 per solver)
    import gc

    from petsc4py import PETSc

    def count():
        gc.collect()
        return len(PETSc.Options().getAll())

    before = count()
    closed = Model(BASE)
    closed.solve()
    assert len(PETSc.Options().getAll()) > before  # the solver's own, while the model may solve again
    closed.close()
    assert len(PETSc.Options().getAll()) == before
    assert closed.solve()["usum_mm"] > 0  # a closed model builds its solver again
    dropped = Model(BASE)
    dropped.solve()
    del closed, dropped
    assert count() == before
