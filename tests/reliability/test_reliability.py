"""Issue 15's cases, one test each: scenes are data, bad input is one line (exit 2) before any meshing.

docs/reliability.md lists every case with its command, what is expected and what was observed.
The scene-level cases call the scene reader directly; the command-line cases run ``suture-fem`` in
process and check the exit code, the single line and that no output folder was created.
"""

from __future__ import annotations

import json
import os
import signal
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
        _refuse_open(monkeypatch)
    assert "cannot be read: Permission denied" in _error(str(locked))


def _refuse_open(monkeypatch):
    """The scene reader's open fails as it does for a user without read permission."""
    real_open = os.open

    def refuse(path, *args, **kwargs):
        if str(path).endswith(".toml"):
            raise PermissionError(13, "Permission denied", str(path))
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", refuse)


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
    # gmsh meshes the paper scene with 12,665 triangles at refinement 0 (sharp rims, the default) and
    # with 14,484 with the recommended geometry.cone_fillet_mm = 0.04 and its fillet refinement
    assert 0.8 * 12665 < coarse.cells < 1.2 * 12665
    rounded = parse_scene("paper", ["geometry.cone_fillet_mm=0.04"])
    assert 0.8 * 14484 < check_fits(Geometry.from_section(rounded.geometry), rounded.mesh).cells < 1.2 * 14484
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
    _refuse_open(monkeypatch)
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


# ----------------------------------------------------------------------------- files: complete or absent

FAST_RUN = ["--set", "mesh.degree=1", "--set", "loading.force_n=1.0"]


@pytest.fixture
def small_disk(tmp_path):
    """A mount of ``size`` KiB (tmpfs); skipped where mounting is not allowed; unmounted afterwards."""
    import subprocess

    mounted = []

    def mount(size_kib: int) -> Path:
        point = tmp_path / f"disk{len(mounted)}"
        point.mkdir()
        proc = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k", "tmpfs", str(point)],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()}")
        mounted.append(point)
        return point

    try:
        yield mount
    finally:
        for point in mounted:  # lazily: a library may still hold a file open there
            subprocess.run(["umount", "-l", str(point)], check=False)


@pytest.mark.parametrize("size_kib", [300, 450])  # full while writing the mesh / while writing the fields
def test_fields_on_a_full_disk(size_kib, small_disk, capsys):
    # B3: a truncated fields.h5/.xdmf was moved into place, a traceback, results.json stuck at "running"
    out = small_disk(size_kib) / "run"
    code, err = _cli(["run", "paper", *FAST_RUN, "--fields", "--no-pictures", "--out", str(out)], capsys)
    assert code == 1 and len(err) == 1 and "fields.h5" in err[0] and "free" in err[0], err
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]  # no partial field files, no temporary files
    results = json.loads((out / "results.json").read_text())
    assert results["status"] == "failed" and "fields.h5" in results["error"]


def test_a_mesh_on_a_full_disk_is_not_renamed_into_place(small_disk, capsys):
    # B4: gmsh does not report a short write; the truncated .msh was renamed into place
    disk = small_disk(200)
    code, err = _cli(["mesh", "paper", "--out", str(disk / "paper.msh")], capsys)
    assert code == 1 and len(err) == 1 and "paper.msh" in err[0] and "nothing was written" in err[0], err
    assert list(disk.iterdir()) == []


def test_mesh_out_must_name_a_msh_file(tmp_path, capsys):
    # B12: --out X.json wrote the mesh to X.json, then the JSON record over it
    code, err = _cli(["mesh", "paper", "--out", str(tmp_path / "X.json")], capsys)
    assert code == 2 and len(err) == 1 and "must end in .msh" in err[0] and "X.msh" in err[0], err
    # B13: --out EXISTING_DIR was a traceback and left DIR.part.msh behind
    code, err = _cli(["mesh", "paper", "--out", str(tmp_path)], capsys)
    assert code == 2 and len(err) == 1 and "is a folder" in err[0], err
    assert list(tmp_path.iterdir()) == []


def test_write_text_leaves_the_old_file_or_the_new_one(tmp_path, monkeypatch):
    from suture_fem.support import io

    target = tmp_path / "results.json"
    io.write_text(target, "old\n")

    def short_fsync(fd):  # the disk fills while flushing
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(io.os, "fsync", short_fsync)
    with pytest.raises(io.WriteError, match="No space left on device"):
        io.write_text(target, "new\n")
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["results.json"]


# ----------------------------------------------------------------------------- what a person sees

def test_a_run_draws_pictures_prints_the_tissue_table_and_removes_stale_files(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    for stale in ("fields.xdmf", "fields.h5", "usum.png", "interface.png"):
        (out / stale).write_text("from an earlier run")
    from suture_fem.cli.main import main

    assert main(["run", "paper", *FAST_RUN, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["force_displacement.png", "interface.png", "results.json",
                                                     "usum.png"]
    for png in ("usum.png", "interface.png"):
        assert (out / png).read_bytes()[:4] == b"\x89PNG" and (out / png).stat().st_size > 10_000
    assert "tissue SEQV" in printed and "maximum over quadrature points" in printed and "MPa at r =" in printed
    assert str(out / "usum.png") in printed and str(out / "force_displacement.png") in printed
    assert "interface: thread tied, cones tied" in printed and "load passed to the tissue (N): cone 1" in printed
    results = json.loads((out / "results.json").read_text())
    assert results["status"] == "converged" and results["process"]["pid"] == os.getpid()


def test_a_picture_that_fails_never_costs_the_results(tmp_path, capsys, monkeypatch):
    from suture_fem import plots
    from suture_fem.cli.main import main

    def broken(*args, **kwargs):
        raise RuntimeError("no OpenGL")

    monkeypatch.setattr(plots, "render_usum", broken)
    out = tmp_path / "run"
    assert main(["run", "paper", *FAST_RUN, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "no OpenGL" in captured.err and "Traceback" not in captured.err
    assert json.loads((out / "results.json").read_text())["status"] == "converged"
    assert (out / "force_displacement.png").exists() and not (out / "usum.png").exists()


# ----------------------------------------------------------------------------- signals

@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signal_ends_the_run_cleanly(signum, code, tmp_path):
    import subprocess
    import sys
    import time

    from tests.conftest import mpi_env

    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", "--set", "mesh.degree=1",
                             "--no-pictures", "--out", str(out)], stderr=subprocess.PIPE, text=True, env=mpi_env())
    try:
        while proc.poll() is None:  # wait for the first converged step
            try:
                if len(json.loads((out / "results.json").read_text())["force_displacement"]) > 1:
                    break
            except (OSError, ValueError):
                pass
            time.sleep(0.1)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=300)
    finally:
        proc.kill()
    assert proc.returncode == code, err
    assert "Traceback" not in err and f"interrupted ({signal.Signals(signum).name})" in err
    results = json.loads((out / "results.json").read_text())
    assert results["status"] == "interrupted" and len(results["force_displacement"]) > 1
    assert results["process"]["pid"] == proc.pid


# ----------------------------------------------------------------------------- one sweep per folder

def test_a_second_sweep_into_the_same_folder_is_refused(tmp_path, capsys):
    from suture_fem.studies.sweep.folders import take_lock

    sweep = tmp_path / "s.toml"
    sweep.write_text('base = "paper"\n[grid]\n"geometry.cones" = [1, 2]\n')
    out = tmp_path / "out"
    held = take_lock(out)  # as the first sweep does, for its life
    try:
        code, err = _cli(["sweep", str(sweep), "--out", str(out)], capsys)
    finally:
        held.close()
    assert code == 2 and len(err) == 1 and f"in use by process {os.getpid()}" in err[0], err
    assert sorted(p.name for p in out.iterdir()) == [".sweep.lock"]  # nothing solved


# ----------------------------------------------------------------------------- the first run's compiler

def test_the_first_compilation_is_one_line(tmp_path):
    import subprocess
    import sys

    probe = tmp_path / "probe.py"
    probe.write_text(
        "from mpi4py import MPI\n"
        "from suture_fem.support.logging import setup_logging\n"
        "setup_logging(MPI.COMM_WORLD)\n"
        "import dolfinx.fem, dolfinx.mesh, ufl\n"
        "from suture_fem.support import compat\n"
        "m = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)\n"
        "u = dolfinx.fem.Function(compat.scalar_space(m, 'Lagrange', 1))\n"
        "compat.form(u * u * ufl.dx)\n"  # as the package builds its forms
        "compat.form(u * u * u * ufl.dx)\n")
    env = {**os.environ, "HOME": str(tmp_path)}  # an empty form cache: everything compiles
    env.pop("XDG_CACHE_HOME", None)
    err = subprocess.run([sys.executable, "-P", str(probe)], capture_output=True, text=True, env=env).stderr
    assert err.count("compiling forms (first run only") == 1 and "gcc" not in err, err
