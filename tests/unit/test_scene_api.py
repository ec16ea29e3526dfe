"""Scenes built in code: from a built-in name, a file, dotted keys or sections, validated like scene files."""

from __future__ import annotations

import pytest

from suture_fem.scene import Scene, parse_scene
from suture_fem.scene.model import MaterialSpec, MaterialsSection
from suture_fem.scene.schema import GeometrySection, LoadingSection, Params, SolverSection
from suture_fem.support.errors import SceneError


def test_every_way_of_building_a_scene_gives_the_scene_the_command_line_reads(tmp_path):
    cli = parse_scene("paper", ["geometry.cones=2", "loading.force_n=1.5"])
    assert Scene.builtin("paper").with_values({"geometry.cones": 2, "loading.force_n": 1.5}) == cli
    (tmp_path / "two.toml").write_text("[geometry]\ncones = 2\n")
    assert Scene.from_file(tmp_path / "two.toml") == parse_scene(tmp_path / "two.toml")
    defaults = parse_scene(None, ["geometry.cones=2", "loading.force_n=1.5"])
    assert Scene.from_values({"geometry.cones": 2, "loading.force_n": 1.5}) == defaults
    assert Scene.of(geometry=GeometrySection(cones=2), loading=LoadingSection(force_n=1.5)) == defaults
    assert Scene.of() == parse_scene(None) == Scene.from_values()


def test_a_section_built_in_code_has_the_defaults_of_defaults_toml():
    scene = parse_scene(None)
    assert GeometrySection() == scene.geometry and MaterialsSection() == scene.materials
    two = GeometrySection(cones=2)
    assert two.cones == 2 and two.cone_height_mm == scene.geometry.cone_height_mm
    assert LoadingSection(force_n=2).force_n == 2.0 and isinstance(LoadingSection(force_n=2).force_n, float)
    assert LoadingSection(report_forces_n=[1, 2]).report_forces_n == (1.0, 2.0)
    assert SolverSection(petsc_options={"snes_max_it": 30}).petsc_options == Params.of({"snes_max_it": 30})


@pytest.mark.parametrize("build, words", [
    (lambda: GeometrySection(cones=100), ["scene key geometry.cones = 100", "<= 64"]),
    (lambda: GeometrySection(cone_kind="solid"), ["geometry.cone_kind", '"hollow"']),
    (lambda: LoadingSection(force_n=-1.0), ["loading.force_n", ">= 1e-06"]),
    (lambda: Scene.builtin("nope"), ["'nope'", "paper"]),
    (lambda: Scene.builtin("paper").with_values({"geometry.conez": 3}), ["geometry.conez", "geometry.cones"]),
    (lambda: Scene.from_values({"mesh.refinement": 9}), ["mesh.refinement", "<= 6"]),
    (lambda: Scene.of(solver=SolverSection(initial_step=0.9, max_step=0.5)), ["solver.max_step"]),
    (lambda: Scene.of(materials=MaterialsSection(dermis=MaterialSpec("yeoh", Params.of({"mu": 3.0})))),
     ["materials.dermis.mu", "yeoh"]),
    (lambda: Scene.of(geometri=GeometrySection()), ["geometri"]),
])
def test_a_bad_value_in_code_is_one_line_naming_the_key_and_range(build, words):
    with pytest.raises(SceneError) as err:
        build()
    assert "\n" not in str(err.value)
    for w in words:
        assert w in str(err.value), (w, str(err.value))
