"""End-to-end runs of `suture-fem run` on coarse scenes: balance, the paper's trends, the CLI contract."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.conftest import FAST, cli, run_inprocess

CONES = (0, 1, 2, 4)
RAMP = ["loading.force_n=2.0", "loading.report_forces_n=[0.5, 1.0]"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One 0-2 N ramp per cone count (degree 1, coarsest mesh); the 2-cone run also writes fields."""
    out = {}
    for n in CONES:
        extra = ["output.fields=true"] if n == 2 else []
        folder = tmp_path_factory.mktemp(f"cones{n}")
        out[n] = (run_inprocess("paper", FAST + RAMP + [f"geometry.cones={n}"] + extra, folder), folder)
    return out


def at(results: dict, force: float) -> dict:
    return next(r for r in results["at_forces"] if abs(r["force_n"] - force) < 1e-9)


REQUIRED = [
    "usum_mm", "seqv_pa", "eptoeqv", "regions", "reaction_force_n", "strain_energy_j", "force_displacement",
    "dofs", "cells", "newton_iterations", "wall_time_s", "dolfinx_version", "scene",
]


@pytest.mark.parametrize("n", CONES)
def test_results_are_complete_finite_and_balanced(runs, n):
    res, folder = runs[n]
    assert res["status"] == "converged"
    for key in REQUIRED:
        assert key in res, key
    for region in ("hypodermis", "dermis", "epidermis", "suture", "tissue"):
        r = res["regions"][region]
        assert all(math.isfinite(r[k]) for k in ("usum_mm", "seqv_pa", "eptoeqv")), region
    assert [r["force_n"] for r in res["at_forces"]] == pytest.approx([0.5, 1.0, 2.0])
    for rec in res["at_forces"]:
        # sum of all residual z-entries is exactly -F, so |reaction + F| <= sqrt(ndofs) * |R_free|
        bound = math.sqrt(res["dofs"]) * rec["free_residual_norm_n"] + 1e-14 * rec["force_n"]
        assert abs(rec["reaction_force_n"] + rec["force_n"]) <= bound
        assert rec["free_residual_norm_n"] <= 1e-8 * rec["force_n"]
    fd = np.array(res["force_displacement"])
    assert fd[0].tolist() == [0.0, 0.0]
    assert np.all(np.diff(fd[:, 0]) > 0) and np.all(np.diff(fd[:, 1]) > 0)
    # the thread pulls along +z, the outer surface holds the tissue back
    assert res["reaction_force_n"] == pytest.approx(-2.0, rel=1e-8)
    assert res["strain_energy_j"] > 0
    assert json.loads((folder / "results.json").read_text())["status"] == "converged"


@pytest.mark.parametrize("n", CONES)
def test_the_near_cone_averages_lie_near_a_cone_and_below_the_tissue_wide_ones(runs, n):
    from suture_fem.geometry.section import Geometry
    from suture_fem.outputs.critical_distance import CONE_ZONE_RADII, cone_distance
    from suture_fem.pipeline import load_scene

    res, _ = runs[n]
    cones = Geometry.from_section(load_scene("paper", FAST + RAMP + [f"geometry.cones={n}"]).geometry).cones
    radius = res["scene"]["output"]["critical_distance_mm"]
    for rec in res["at_forces"]:
        tissue = rec["regions"]["tissue"]
        for key in ("seqv_cd_pa", "eptoeqv_cd"):
            near = key.replace("_cd", "_cd_cone")
            if n == 0:  # no cone: no near-cone value
                assert near not in tissue
                continue
            centre = np.array([tissue[near + "_at_mm"]])
            assert cone_distance(cones, centre)[0] <= CONE_ZONE_RADII * radius + 1e-9
            assert 0 < tissue[near] <= tissue[key]
            if cone_distance(cones, np.array([tissue[key + "_at_mm"]]))[0] <= CONE_ZONE_RADII * radius:
                assert tissue[near] == tissue[key]  # the tissue-wide disc is near a cone: the same disc


def test_usum_falls_as_cones_are_added(runs):
    usum = [at(runs[n][0], 1.0)["usum_mm"] for n in CONES]
    assert all(a > b for a, b in zip(usum, usum[1:])), usum


@pytest.mark.parametrize("n", CONES)
def test_usum_grows_less_than_linearly_with_force(runs, n):
    res = runs[n][0]
    u = [at(res, f)["usum_mm"] for f in (0.5, 1.0, 2.0)]
    assert u[0] < u[1] < u[2]
    assert u[1] < 2 * u[0] and u[2] < 2 * u[1], u


def test_thread_stress_is_force_over_thread_area(runs):
    # the free thread carries F / (pi r_t^2) (plus the Poisson/hoop part of an SVK rod, which is nil here)
    res = runs[1][0]
    r_t = res["scene"]["geometry"]["thread_radius_mm"] * 1e-3
    nominal = 2.0 / (math.pi * r_t**2)
    assert res["regions"]["suture"]["seqv_pa"] >= nominal * (1 - 1e-3)


def test_fields_are_written_when_asked(runs):
    folder = runs[2][1]
    assert (folder / "fields.xdmf").is_file() and (folder / "fields.h5").is_file()
    assert not list(folder.glob(".*.tmp"))


def test_bad_scene_exits_2_with_one_line_and_no_traceback(tmp_path):
    proc = cli(["run", "paper", "--set", "geometry.cone_spacing_mm=1.0", "--out", str(tmp_path / "x")])
    assert proc.returncode == 2
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert "geometry.cone_spacing_mm" in lines[0] and "overlap" in lines[0]
    assert not (tmp_path / "x").exists()  # stopped before meshing, nothing written


def test_mesh_command_writes_msh_and_record(tmp_path):
    proc = cli(["mesh", "paper", "--set", "geometry.cones=1", "--out", str(tmp_path / "one.msh")])
    assert proc.returncode == 0, proc.stderr
    record = json.loads((tmp_path / "one.json").read_text())
    assert record["units"] == "mm" and record["cell_tags"]["cone"] == 5 and record["triangles"] > 0
    assert (tmp_path / "one.msh").stat().st_size > 0


def test_without_the_layers_averages_the_tissue_values_stay_and_the_layers_have_none(runs, tmp_path):
    """``output.critical_distance_layers = false`` skips each layer's own search; the tissue's are the same values."""
    res = run_inprocess("paper", FAST + RAMP + ["geometry.cones=1", "output.critical_distance_layers=false"], tmp_path)
    with_layers, _ = runs[1]
    names = ("seqv_cd_pa", "eptoeqv_cd", "seqv_cd_cone_pa", "eptoeqv_cd_cone")
    for rec, ref in zip(res["at_forces"], with_layers["at_forces"], strict=True):
        for name in names:
            assert rec["regions"]["tissue"][name] == ref["regions"]["tissue"][name]
            assert rec["regions"]["tissue"][name + "_at_mm"] == ref["regions"]["tissue"][name + "_at_mm"]
        assert rec["seqv_cd_pa"] == ref["seqv_cd_pa"] and rec["seqv_cd_pa_region"] == "tissue"
        for layer in ("hypodermis", "dermis", "epidermis"):
            assert "seqv_cd_pa" in ref["regions"][layer] and "seqv_cd_pa" not in rec["regions"][layer]
            assert rec["regions"][layer]["seqv_pa"] == ref["regions"][layer]["seqv_pa"]  # the rest as before
