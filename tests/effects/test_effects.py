"""Simulate only the effects a scene calls for: what is off is truly absent, what is on does its job.

Degree 1, coarsest mesh (FAST). The paper-scene evidence (rigid vs elastic, damped hold, wall times)
is benchmarks/effects.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.physics.constraints import FREE
from suture_fem.physics.effects import HOLD_SKIPPED
from suture_fem.physics.problem import build_physics
from suture_fem.pipeline import load_scene, run_scene
from suture_fem.support import compat
from tests.conftest import FAST

BASE = FAST + ["loading.report_forces_n=[]"]
#: |reaction + F - weight| / F after a converged solve (Newton stops at |R| <= 1e-10 N on ~1 N loads)
BALANCE_TOL = 1e-6


def physics_of(overrides: list[str]):
    scene = load_scene("paper", BASE + overrides)
    return build_physics(meshmod.create_mesh(MPI.COMM_SELF, scene.geometry, scene.mesh), scene), scene


def solve(overrides: list[str], out, quantities_check=None):
    """run_scene on BASE + overrides; returns (results, physics at the last report)."""
    scene = load_scene("paper", BASE + overrides)
    kept = {}
    results = run_scene(scene, out, MPI.COMM_SELF, on_report=lambda f, outputs: kept.update(physics=outputs.physics))
    return results, kept["physics"]


@pytest.fixture(scope="module")
def elastic(tmp_path_factory):
    return solve([], tmp_path_factory.mktemp("elastic"))


def suture_nodes(physics) -> np.ndarray:
    V = physics.V
    cells = meshmod.region_cells(physics.tagged, regions.SUTURE)
    return np.unique(compat.cell_dofs(V)[cells])


def coefficient_names(form) -> set[str]:
    return {c.name for c in form.coefficients()}


def test_default_scene_builds_only_elasticity_and_the_pull(elastic):
    results, physics = elastic
    assert sorted(physics.terms) == ["elastic:dermis", "elastic:epidermis", "elastic:hypodermis", "elastic:suture",
                                     "pull"]
    assert physics.dynamics is None and physics.gravity_factor is None
    # no history functions: no mass or damping form exists, so none was compiled or assembled
    assert coefficient_names(physics.residual) == {"displacement"}
    # (tissue_residual: the interface output's load shares, a default quantity)
    assert set(physics.compiled()) <= {"residual", "jacobian", "energy", "end_displacement", "tissue_residual"}
    rec = results["effects"]
    assert rec["inertia"]["on"] is False and "no mass" in rec["inertia"]["left_out"]
    assert rec["hold"] == {"solved": False, "left_out": HOLD_SKIPPED}
    assert rec["gravity"]["on"] is False and rec["suture"]["treatment"] == "elastic"
    assert "time_history" not in results


def test_inertia_adds_mass_and_only_the_damping_it_is_given():
    physics, _ = physics_of(["effects.inertia=true", "effects.rayleigh_mass_per_s=50"])
    assert {"inertia", "damping:mass"} <= set(physics.terms) and "damping:stiffness" not in physics.terms
    assert {"w_n", "v_n", "a_n"} <= coefficient_names(physics.residual)
    physics, _ = physics_of(["effects.inertia=true"])
    assert "inertia" in physics.terms and not any(t.startswith("damping") for t in physics.terms)


def test_rigid_suture_solves_for_one_motion_instead_of_the_suture_unknowns(elastic, tmp_path):
    el_results, el_physics = elastic
    # count the suture's free unknowns of the elastic problem, independently of the rigid code path
    nodes = suture_nodes(el_physics)
    dofs = (2 * nodes[:, None] + np.arange(2)).ravel()
    suture_free = int(np.count_nonzero(el_physics.unknowns.kind[dofs] == FREE))
    results, physics = solve(["effects.suture=rigid"], tmp_path)
    nodes = suture_nodes(physics)
    assert results["unknowns"] == el_results["unknowns"] - suture_free + 1
    assert results["dofs"] == el_results["dofs"]  # same mesh; only what is solved for changed
    assert "elastic:suture" not in physics.terms
    rec = results["effects"]["suture"]
    assert rec["treatment"] == "rigid" and rec["rigid_unknowns"] == 1
    # every suture node moves by the same d: the thread end's displacement is the suture's USUM
    u = physics.u.x.array.reshape(-1, 2)[nodes]
    assert np.all(u[:, 0] == 0.0) and np.ptp(u[:, 1]) == 0.0
    assert results["regions"]["suture"]["usum_mm"] == pytest.approx(results["thread_end_displacement_mm"], rel=1e-12)
    assert results["status"] == "converged" and results["force_balance_rel"] < BALANCE_TOL
    assert results["free_residual_norm_n"] <= 1e-8 * results["applied_force_n"]
    # removing the thread's stretch can only shorten the pull: the rigid thread end moves less
    assert results["usum_mm"] < el_results["usum_mm"]


def test_only_usum_requested_compiles_no_stress_or_strain_expression(tmp_path, monkeypatch):
    compiled = []
    real = compat.expression

    def recording(expr, points):
        compiled.append(expr.ufl_shape)
        return real(expr, points)

    monkeypatch.setattr(compat, "expression", recording)
    results, physics = solve(['output.quantities=["usum"]'], tmp_path)
    # the domain guard's scalar limits and its coordinates are all there is; the outputs' 8-component
    # (stress, B) expression never exists
    assert (8,) not in compiled and all(shape in ((), (2,)) for shape in compiled)
    assert "usum_mm" in results and "seqv_pa" not in results and "eptoeqv" not in results
    rec = results["effects"]["outputs"]
    assert rec["computed"] == ["usum"] and set(rec["left_out"]) == {"seqv", "eptoeqv", "interface"}


def test_gravity_weighs_the_tissue_down_and_balances(tmp_path, elastic):
    results, physics = solve(["effects.gravity=true"], tmp_path)
    weight = results["effects"]["gravity"]["weight_n"]
    # the weight from the mesh volumes and the scene densities, about 1 g of tissue
    assert 5e-3 < weight < 2e-2
    assert "gravity" in physics.terms
    # outer surface, pull and weight (along -z) balance
    F = results["applied_force_n"]
    assert abs(results["reaction_force_n"] + F - weight) < BALANCE_TOL * F
    # the weight hangs the tissue against the pull: the thread end moves a little less than without it
    assert results["thread_end_displacement_mm"] < elastic[0]["thread_end_displacement_mm"]


@pytest.mark.long  # 15-25 s: benchmarks/long_tests.py runs it
def test_damped_hold_converges_to_the_quasi_static_answer(tmp_path, elastic):
    """A 20 ms ramp sets the thread end ringing (period about 3.7 ms); Rayleigh damping (alpha = 400/s: an
    e-folding time 2 / alpha = 5 ms; beta = 1e-4 s for the stiff suture's modes) together with the
    numerical damping of generalized-alpha at 4 ms steps lets the 0.1 s hold settle on the quasi-static state."""
    results, physics = solve(["effects.inertia=true", "loading.ramp_s=0.02", "loading.hold_s=0.1",
                              "effects.time_step_s=0.004", "effects.rayleigh_mass_per_s=400",
                              "effects.rayleigh_stiffness_s=1e-4"], tmp_path)
    assert {"inertia", "damping:mass", "damping:stiffness"} <= set(physics.terms)
    assert results["effects"]["hold"]["solved"] is True
    history = np.array(results["time_history"])
    assert history[-1, 0] == pytest.approx(0.12, rel=1e-12) and np.all(np.diff(history[:, 0]) > 0)
    assert np.all(history[history[:, 0] >= 0.02 - 1e-12, 1] == pytest.approx(1.0))  # held at the peak
    quasi_static = elastic[0]["usum_mm"]
    assert results["usum_mm"] == pytest.approx(quasi_static, rel=0.01)  # the criterion
    assert all(math.isfinite(v) for v in history.ravel())
