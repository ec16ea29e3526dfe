"""Issue 15's cases, one test each: scenes are data, bad input is one line (exit 2) before any meshing.

docs/reliability.md lists every case with its command, what is expected and what was observed.
The scene-level cases call the scene reader directly; the command-line cases run ``suture-fem`` in
process and check the exit code, the single line and that no output folder was created.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from suture_fem.scene.load import parse_scene
from suture_fem.support.errors import SceneError


def _error(source, overrides=()):
    with pytest.raises(SceneError) as err:
        parse_scene(source, list(overrides))
    message = str(err.value)
    assert "\n" not in message
    return message


# ----------------------------------------------------------------------------- B1, B2, B5: PETSc options

@pytest.mark.parametrize("option", [
    '{pc_type = "python", pc_python_type = "evil.Attr"}',  # B1: PETSc would import and call any module
    '{snes_monitor = "ascii:/tmp/suture_fem_b2.txt"}',  # B2: viewers and monitors write files
    '{snes_view = "ascii:/tmp/suture_fem_b2.txt"}',
    '{ksp_view_mat = "binary:/tmp/suture_fem_b2.bin"}',
    '{options_file = "/tmp/suture_fem_b2.opts"}',
    '{log_view = "ascii:/tmp/suture_fem_b2.log"}',
])
def test_petsc_options_outside_the_declared_set_are_refused(option):
    message = _error("paper", [f"solver.petsc_options={option}"])
    assert "solver.petsc_options." in message
    assert "allowed" in message or "expected" in message


@pytest.mark.parametrize("override, words", [
    ("solver.petsc_options.snes_linesearch_type=foo", ["snes_linesearch_type", '"bt"', '"basic"']),  # B5
    ("solver.petsc_options.snes_max_it=[3]", ["snes_max_it", "integer"]),
    ("solver.petsc_options.mat_mumps_icntl_14=true", ["mat_mumps_icntl_14", "integer"]),
    ("solver.petsc_options.snes_rtol=-1", ["snes_rtol", "> 0"]),
])
def test_bad_petsc_option_values_are_one_line(override, words):
    message = _error("paper", [override])
    for w in words:
        assert w in message, (w, message)


def test_petsc_option_overrides_merge(tmp_path):
    # B6: each --set solver.petsc_options.KEY=V adds to the table; the scene file's own options stay
    scene_file = tmp_path / "s.toml"
    scene_file.write_text('[solver]\npetsc_options = {snes_linesearch_type = "basic"}\n')
    scene = parse_scene(str(scene_file), ["solver.petsc_options.mat_mumps_icntl_14=300",
                                          "solver.petsc_options.snes_max_funcs=5000"])
    assert dict(scene.solver.petsc_options) == {"snes_linesearch_type": "basic", "mat_mumps_icntl_14": 300,
                                                "snes_max_funcs": 5000}


# ----------------------------------------------------------------------------- B7: names and paths

def test_a_builtin_name_is_never_hidden_by_a_file_of_that_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()
    assert parse_scene("paper").geometry.cones == 4  # the built-in scene
    assert "is a folder" in _error("./paper")  # the path
    (tmp_path / "mine").write_text("[geometry]\ncones = 2\n")
    message = _error("mine")
    assert "not a built-in scene" in message and "./mine" in message
    assert parse_scene("./mine").geometry.cones == 2


# ----------------------------------------------------------------------------- B8-B10: unreadable files

def test_non_utf8_scene_file(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes("[geometry]\n# Gewebe: Fettgewebe \xfcber der Dermis\ncones = 2\n".encode("latin-1"))
    assert "not UTF-8" in _error(str(bad))


def test_toml_nested_thousands_deep(tmp_path):
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    assert "nested too deeply" in _error(str(deep))
    assert "nested too deeply" in _error("paper", ["solver.petsc_options=" + "[" * 3000 + "]" * 3000])


def test_unreadable_scene_file(tmp_path, monkeypatch):
    locked = tmp_path / "locked.toml"
    locked.write_text("[geometry]\ncones = 2\n")
    locked.chmod(0)
    if os.access(locked, os.R_OK):  # root reads anything: make the read fail as it does for a user
        def refuse(self):
            raise PermissionError(13, "Permission denied", str(self))

        monkeypatch.setattr(Path, "read_bytes", refuse)
    assert "cannot be read: Permission denied" in _error(str(locked))


# ----------------------------------------------------------------------------- B14: physical lengths

@pytest.mark.parametrize("key", ["geometry.epidermis_mm", "geometry.cone_wall_mm", "geometry.thread_radius_mm",
                                 "mesh.size_rim_mm"])
def test_lengths_have_a_physical_lower_bound(key):
    message = _error("paper", [f"{key}=1e-300"])
    assert key in message and ">= 0.001" in message


# ----------------------------------------------------------------------------- a mesh that cannot fit

def test_a_mesh_too_large_for_the_machine_is_refused_before_meshing():
    from suture_fem.pipeline import load_scene

    with pytest.raises(SceneError) as err:
        load_scene("paper", ["mesh.refinement=6"])
    message = str(err.value)
    assert "\n" not in message and "mesh.refinement = 6" in message
    assert "cells" in message and "GiB" in message


def test_the_mesh_estimate_is_close_to_gmsh_and_scales_with_refinement():
    from suture_fem.geometry.estimate import check_fits
    from suture_fem.geometry.section import Geometry

    scene = parse_scene("paper")
    geometry = Geometry.from_section(scene.geometry)
    coarse = check_fits(geometry, scene.mesh)
    # gmsh meshes the paper scene with 12,665 triangles at refinement 0 (docs/reliability.md)
    assert 0.8 * 12665 < coarse.cells < 1.2 * 12665
    fine = check_fits(geometry, parse_scene("paper", ["mesh.refinement=1"]).mesh)
    assert 3.0 < fine.cells / coarse.cells < 4.5  # halving every size: about four times the cells
    with pytest.raises(SceneError, match="needing about"):
        check_fits(geometry, scene.mesh, memory_gib=0.01)


# ----------------------------------------------------------------------------- the command line, in process

def _cli(args, capsys):
    """``suture-fem ARGS`` in this process: (exit code, its error lines); no traceback allowed."""
    from suture_fem.cli.main import main

    code = main(list(args))
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, [line for line in err.splitlines() if line.startswith("suture-fem: error:")]


# ----------------------------------------------------------------------------- B1: child processes

ROOT = Path(__file__).resolve().parents[2]


def test_no_child_python_has_the_current_folder_on_its_module_path():
    # B1: `python -m` puts the current folder first on sys.path, so an evil.py (or a folder named
    # suture_fem) beside the scene would run in every rung; `python -P -m` does not.
    offenders = []
    for folder in ("suture_fem", "benchmarks", "tests"):
        for path in (ROOT / folder).rglob("*.py"):
            text = path.read_text()
            for needle in ("sys.executable, " + '"-m"', "PYTHON, " + '"-m"'):
                if needle in text:
                    offenders.append(f"{path.relative_to(ROOT)}: {needle}")
    assert offenders == []


def test_python_dash_p_ignores_a_module_in_the_current_folder(tmp_path):
    import subprocess
    import sys

    shadow = tmp_path / "suture_fem"
    shadow.mkdir()
    (shadow / "__init__.py").write_text(f"open({str(tmp_path / 'ran')!r}, 'w').write('evil')\n")
    (shadow / "cli.py").write_text("")
    proc = subprocess.run([sys.executable, "-P", "-m", "suture_fem.cli", "scenes"], cwd=tmp_path,
                          capture_output=True, text=True)
    assert proc.returncode == 0 and "paper" in proc.stdout
    assert not (tmp_path / "ran").exists()


# ----------------------------------------------------------------------------- B8-B11: sweep files

def _sweep_error(tmp_path, content: bytes | str, name="s.toml"):
    from suture_fem.studies.sweep import SweepError, load_sweep

    path = tmp_path / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(SweepError) as err:
        load_sweep(path)
    assert err.value.exit_code == 2 and "\n" not in str(err.value)
    return str(err.value)


def test_non_utf8_sweep_file(tmp_path):
    text = 'base = "paper"\n# Stra\xdfe\n[grid]\n"geometry.cones" = [1, 2]\n'
    assert "not UTF-8" in _sweep_error(tmp_path, text.encode("latin-1"))


def test_sweep_file_nested_thousands_deep(tmp_path):
    assert "nested too deeply" in _sweep_error(tmp_path, 'base = "paper"\nx = ' + "[" * 5000 + "]" * 5000 + "\n")


def test_unreadable_sweep_file(tmp_path, monkeypatch):
    def refuse(self):
        raise PermissionError(13, "Permission denied", str(self))

    monkeypatch.setattr(Path, "read_bytes", refuse)
    assert "cannot be read: Permission denied" in _sweep_error(tmp_path, 'base = "paper"\n')


def test_sweep_file_that_is_a_folder(tmp_path):
    from suture_fem.studies.sweep import SweepError, load_sweep

    with pytest.raises(SweepError, match="is a folder"):
        load_sweep(tmp_path)


def test_sweep_out_must_be_a_string(tmp_path, capsys):
    # B11: `out = 5` was a TypeError traceback, exit 1
    sweep = tmp_path / "s.toml"
    sweep.write_text('base = "paper"\nout = 5\n[grid]\n"geometry.cones" = [1, 2]\n')
    code, err = _cli(["sweep", str(sweep)], capsys)
    assert code == 2 and len(err) == 1 and "key out" in err[0] and "string" in err[0], err


# ----------------------------------------------------------------------------- B15: an empty ladder

@pytest.mark.parametrize("option", ["--degrees", "--refinements"])
def test_convergence_with_an_empty_ladder_is_refused(option, tmp_path, capsys):
    out = tmp_path / "ledger"
    code, err = _cli(["convergence", "paper", option, "", "--out", str(out)], capsys)
    assert code == 2 and len(err) == 1 and option in err[0], err
    assert not out.exists()
