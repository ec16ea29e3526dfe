"""Sweep files: expansion, stable folder names, and one clear line for a malformed file (no MPI, no solve)."""

from __future__ import annotations

import pytest

from suture_fem.scene import parse_override
from suture_fem.studies.sweep import SweepError, load_sweep, toml_value

GRID = """
base = "paper"
[set]
"mesh.degree" = 1
[grid]
"geometry.cones" = [1, 2, 3]
loading.force_n = [1.0, 2.5]
"""


def write(tmp_path, text, name="s.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_grid_is_every_combination_first_key_slowest(tmp_path):
    sweep = load_sweep(write(tmp_path, GRID))
    assert [(c.varied["geometry.cones"], c.varied["loading.force_n"]) for c in sweep.cases] == [
        (1, 1.0), (1, 2.5), (2, 1.0), (2, 2.5), (3, 1.0), (3, 2.5)]
    assert sweep.varied_keys == ["geometry.cones", "loading.force_n"]
    assert all(c.scene.mesh.degree == 1 for c in sweep.cases)
    assert [c.scene.geometry.cones for c in sweep.cases] == [1, 1, 2, 2, 3, 3]


def test_folder_names_are_stable_and_follow_the_scene(tmp_path):
    a = load_sweep(write(tmp_path, GRID, "a.toml"))
    b = load_sweep(write(tmp_path, GRID, "b.toml"))
    assert [c.name for c in a.cases] == [c.name for c in b.cases]
    assert len({c.name.split("-")[1] for c in a.cases}) == len(a.cases)
    changed = load_sweep(write(tmp_path, GRID.replace('"mesh.degree" = 1', '"mesh.degree" = 2'), "c.toml"))
    assert not {c.name for c in changed.cases} & {c.name for c in a.cases}
    assert load_sweep(write(tmp_path, GRID), ["mesh.refinement=1"]).cases[0].name != a.cases[0].name


def test_overrides_round_trip_through_set(tmp_path):
    for value in (1, 2.5, 1e-5, True, "hollow", [1.0, 2.0], {"snes_linesearch_type": "basic"}):
        assert parse_override(f"k={toml_value(value)}")[1] == value


def test_an_invalid_scene_is_a_case_with_its_error(tmp_path):
    sweep = load_sweep(write(tmp_path, 'base = "paper"\n[[scenes]]\n"geometry.cones" = 2\n[[scenes]]\n'
                                      '"mesh.degree" = 7\n'))
    assert sweep.cases[0].error is None and sweep.cases[1].scene is None
    assert "mesh.degree" in sweep.cases[1].error


@pytest.mark.parametrize("text, key", [
    ('[grid]\n"geometry.cones" = [1]\n', "base"),
    ('base = "paper"\n', "exactly one of"),
    ('base = "paper"\n[grid]\n"geometry.cones" = 2\n', "geometry.cones"),
    ('base = "paper"\nsets = {}\n[grid]\n"geometry.cones" = [2]\n', "sets"),
    ('base = "paper"\n[grid]\n', "empty"),
    ('base = "paper"\nscenes = 3\n', "scenes"),
])
def test_a_malformed_sweep_file_is_one_line_naming_the_key(tmp_path, text, key):
    with pytest.raises(SweepError, match=key) as err:
        load_sweep(write(tmp_path, text))
    assert "\n" not in str(err.value) and err.value.exit_code == 2


def test_folder_names_follow_the_base_scene_file(tmp_path):
    (tmp_path / "base.toml").write_text("[geometry]\ncones = 2\n")
    text = 'base = "base.toml"\n[grid]\n"loading.force_n" = [1.0]\n'
    before = load_sweep(write(tmp_path, text)).cases[0]
    assert before.scene.geometry.cones == 2
    (tmp_path / "base.toml").write_text("[geometry]\ncones = 3\n")
    assert load_sweep(write(tmp_path, text)).cases[0].name != before.name


def test_an_unreadable_base_scene_is_a_sweep_error(tmp_path):
    with pytest.raises(SweepError, match="base"):
        load_sweep(write(tmp_path, 'base = "missing.toml"\n[grid]\n"geometry.cones" = [1]\n'))
