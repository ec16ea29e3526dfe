"""`suture-fem convergence --refine fillet`: the ladder that refines only the rounded rims (no solving).

Level k doubles ``mesh.fillet_elements`` k times at the scene's ``mesh.refinement``; a scene with
sharp rims, or a level beyond the key's maximum, is refused in one line (exit 2) before any meshing.
"""

from __future__ import annotations

import pytest

from suture_fem.pipeline import load_scene
from suture_fem.studies.convergence.ladder import plan_ladder
from suture_fem.studies.convergence.report import markdown
from suture_fem.support.errors import SceneError

ROUNDED = ["geometry.cone_fillet_mm=0.04", "geometry.cones=1"]


def _plan(overrides, levels, degrees=(2,)):
    base = load_scene("paper", overrides)
    return plan_ladder(base, "paper", overrides, list(degrees), list(levels), forces=[1.0], refine="fillet")


@pytest.mark.parametrize("refinement", [0, 1])
def test_each_level_doubles_only_the_fillet_elements(refinement):
    overrides = [*ROUNDED, f"mesh.refinement={refinement}"]
    base = load_scene("paper", overrides)
    plan = _plan(overrides, range(5)).rungs()
    assert [r.name for r, _ in plan] == [f"p2_fillet{k}" for k in range(5)]
    assert [r.label for r, _ in plan] == [f"P2 fillet{k}" for k in range(5)]
    for k, (rung, scene) in enumerate(plan):
        assert rung.refinement == k and rung.level_name == "fillet"
        assert scene.mesh.fillet_elements == base.mesh.fillet_elements * 2**k == 8 * 2**k
        # everything else is the scene's: the far field keeps its refinement and sizes
        assert scene.mesh.refinement == refinement and scene.mesh.degree == 2
        assert scene.with_values({"mesh.fillet_elements": 8}).as_dict() == base.with_values(
            {"mesh.degree": 2}).as_dict()


def test_the_largest_allowed_level_is_planned_and_the_next_refused():
    assert _plan(ROUNDED, [5]).rungs()[0][1].mesh.fillet_elements == 256  # the key's maximum
    with pytest.raises(SceneError, match="level 6 would put 512 elements .* at most 256"):
        _plan(ROUNDED, [0, 6])
    with pytest.raises(SceneError, match="level 2 would put 400"):
        _plan([*ROUNDED, "mesh.fillet_elements=100"], [0, 1, 2])


def test_sharp_rims_are_refused():
    with pytest.raises(SceneError, match="cone_fillet_mm = 0"):
        _plan(["geometry.cone_fillet_mm=0"], [0, 1])


@pytest.mark.parametrize("bad", [["--set", "geometry.cone_fillet_mm=0", "--refinements", "0,1"],
                                 ["--set", "geometry.cone_fillet_mm=0.04", "--refinements", "0,6"]])
def test_the_command_refuses_in_one_line_before_any_meshing(bad, tmp_path, capsys):
    from suture_fem.cli.main import main

    out = tmp_path / "ledger"
    assert main(["convergence", "paper", *bad, "--degrees", "2", "--refine", "fillet", "--out", str(out)]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and errors[0].startswith("suture-fem: error: --refine fillet: ")
    assert not out.exists()


def test_the_ledger_says_what_its_levels_refine():
    ladder = _plan(ROUNDED, [0, 1, 2])
    assert "fillet levels [0, 1, 2] (only mesh.fillet_elements doubles per level" in markdown("t", ladder, [], {})
    assert "straight-sided cells: each arc is a polygon" in markdown("t", ladder, [], {})
    curved = _plan([*ROUNDED, "mesh.degree=2", "mesh.geometry_degree=2"], [0, 1])
    assert "quadratic cells, their mid-side nodes on the arcs" in markdown("t", curved, [], {})
