"""Nothing from the current folder configures the run, and no write inside --out follows a planted file.

docs/reliability.md, "Files from the current folder and writes inside --out", lists each case with its
command, what is expected and what was observed before and now.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest


def mpi_env():
    from tests.conftest import mpi_env as env

    return env()


def _cli(args, capsys):
    """``suture-fem ARGS`` in this process: (exit code, its error lines); no traceback allowed."""
    from suture_fem.cli.main import main

    code = main(list(args))
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, [line for line in err.splitlines() if line.startswith("suture-fem: error:")]


def _suture_fem(args, cwd, **env):
    """``suture-fem ARGS`` as a fresh process started in ``cwd``."""
    return subprocess.run([sys.executable, "-P", "-m", "suture_fem.cli", *args], cwd=cwd, capture_output=True,
                          text=True, env={**mpi_env(), **env})


# ----------------------------------------------------------------------------- PETSc's option files

def test_petsc_reads_no_option_file_and_no_petsc_options(tmp_path):
    # .petscrc / petscrc in the current folder (and PETSC_OPTIONS) were read at PETSc's start-up:
    # -log_view and -history wrote any file, -start_in_debugger -debug_terminal ran any program
    (tmp_path / ".petscrc").write_text(f"-history {tmp_path / 'history.txt'}\n")
    (tmp_path / "petscrc").write_text(f"-log_view :{tmp_path / 'log.txt'}\n")
    proc = _suture_fem(["show", "paper"], tmp_path, PETSC_OPTIONS=f"-history {tmp_path / 'env.txt'}")
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == [".petscrc", "petscrc"]
    assert "PETSC_OPTIONS ignored: PETSc options come only from the scene's solver.petsc_options" in proc.stderr


def test_petsc_started_through_the_package_skips_option_files(tmp_path):
    (tmp_path / ".petscrc").write_text(f"-history {tmp_path / 'history.txt'}\n")
    probe = "import suture_fem.support.compat\nfrom petsc4py import PETSc\nprint(sorted(PETSc.Options().getAll()))\n"
    proc = subprocess.run([sys.executable, "-P", "-c", probe], cwd=tmp_path, capture_output=True, text=True,
                          env={**mpi_env(), "PETSC_OPTIONS": "-snes_monitor"})
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["['skip_petscrc']"]  # neither the file's -history nor PETSC_OPTIONS
    assert not (tmp_path / "history.txt").exists()


@pytest.mark.parametrize("name", ["OMPI_MCA_mca_base_component_path", "OMPI_MCA_mca_base_param_files",
                                  "OMPI_MCA_orte_launch_agent", "PMIX_MCA_mca_base_component_path"])
def test_open_mpi_settings_that_load_or_run_code_are_refused(name, monkeypatch, capsys):
    monkeypatch.setenv(name, "/tmp/elsewhere")
    code, err = _cli(["show", "paper"], capsys)
    assert code == 2 and len(err) == 1 and name in err[0] and "unset it" in err[0], err


# ----------------------------------------------------------------------------- the form compiler's files

def test_jit_parameter_files_in_the_current_folder_are_ignored(tmp_path):
    # dolfinx_jit_parameters.json moved the kernel cache (a shared library shipped there was loaded);
    # ffcx_parameters.json changed how every form is compiled
    (tmp_path / "dolfinx_jit_parameters.json").write_text(json.dumps({"cache_dir": str(tmp_path / "cache")}))
    (tmp_path / "ffcx_parameters.json").write_text(json.dumps({"scalar_type": "float"}))
    probe = ("from mpi4py import MPI\nimport dolfinx.mesh, ufl\nfrom suture_fem.support import compat\n"
             "import dolfinx.jit, ffcx.parameters\n"
             "m = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 2, 2)\n"
             "u = dolfinx.fem.Function(compat.scalar_space(m, 'Lagrange', 1))\n"
             "compat.form(u * u * ufl.dx)\n"
             "print(dolfinx.jit.get_parameters()['cache_dir'], ffcx.parameters.get_parameters()['scalar_type'])\n")
    proc = subprocess.run([sys.executable, "-P", "-c", probe], cwd=tmp_path, capture_output=True, text=True,
                          env=mpi_env())
    assert proc.returncode == 0, proc.stderr
    cache, scalar = proc.stdout.split()
    expected = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "fenics"
    assert Path(cache) == expected and scalar == "double"
    assert not (tmp_path / "cache").exists()


# ----------------------------------------------------------------------------- symlinks planted in --out

@pytest.fixture
def victim(tmp_path):
    path = tmp_path / "victim.txt"
    path.write_text("precious\n")
    return path


def test_no_temporary_file_follows_a_planted_symlink(tmp_path, victim):
    from suture_fem.support import io

    out = tmp_path / "out"
    out.mkdir()
    for guess in (f".results.json.{os.getpid()}.tmp", f".results.json.{os.getpid() + 1}.tmp"):
        (out / guess).symlink_to(victim)  # the old predictable names
    io.write_json(out / "results.json", {"status": "converged"})
    assert victim.read_text() == "precious\n"
    assert json.loads((out / "results.json").read_text()) == {"status": "converged"}
    first = io.temporary_name(out / "results.json")
    second = io.temporary_name(out / "results.json")
    assert first != second and first.name.startswith(".results.json.")  # unpredictable, each created anew


def test_a_symlink_at_the_final_name_is_replaced_not_followed(tmp_path, victim):
    from suture_fem.support import io

    out = tmp_path / "out"
    out.mkdir()
    (out / "results.json").symlink_to(victim)
    io.write_text(out / "results.json", "new\n")
    assert victim.read_text() == "precious\n" and not (out / "results.json").is_symlink()


def test_a_lock_file_that_is_a_symlink_or_a_hard_link_is_refused(tmp_path, victim, capsys):
    from suture_fem.studies.sweep import SweepError
    from suture_fem.studies.sweep.folders import take_lock

    out = tmp_path / "out"
    out.mkdir()
    (out / ".sweep.lock").symlink_to(victim)
    with pytest.raises(SweepError, match="symbolic link"):
        take_lock(out)
    (out / ".sweep.lock").unlink()
    os.link(victim, out / ".sweep.lock")
    with pytest.raises(SweepError, match="hard link"):
        take_lock(out)
    assert victim.read_text() == "precious\n"


def test_a_planted_staging_folder_symlink_is_replaced_not_followed(tmp_path):
    # a sweep scene is solved in OUT/.NNN-HASH.partial: a symlink there made the scene fail (File exists)
    from suture_fem.studies.sweep.folders import fresh_folder

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "keep.txt").write_text("precious\n")
    staging = tmp_path / "out" / ".000-abc.partial"
    staging.parent.mkdir()
    staging.symlink_to(elsewhere, target_is_directory=True)
    fresh_folder(staging)
    assert staging.is_dir() and not staging.is_symlink() and list(staging.iterdir()) == []
    assert (elsewhere / "keep.txt").read_text() == "precious\n"


def test_a_log_file_never_follows_a_symlink(tmp_path, victim):
    from suture_fem.support import io

    (tmp_path / "run.log").symlink_to(victim)
    with pytest.raises(io.WriteError, match="symbolic link"):
        io.open_new(tmp_path / "run.log")
    assert victim.read_text() == "precious\n"


# ----------------------------------------------------------------------------- shared sweep files

@pytest.mark.parametrize("out", ["/tmp/anywhere", "../outside", "results/../../x", "~/x"])
def test_a_sweep_file_may_name_its_folder_only_inside_the_current_folder(out, tmp_path):
    from suture_fem.studies.sweep import SweepError, load_sweep

    sweep = tmp_path / "s.toml"
    sweep.write_text(f'base = "paper"\nout = "{out}"\n[grid]\n"geometry.cones" = [1, 2]\n')
    with pytest.raises(SweepError) as err:
        load_sweep(sweep)
    assert "key out" in str(err.value) and "--out" in str(err.value) and "\n" not in str(err.value)
    assert load_sweep(sweep, out=tmp_path / "mine").out == tmp_path / "mine"  # the command line may
    sweep.write_text('base = "paper"\nout = "results/mine"\n[grid]\n"geometry.cones" = [1, 2]\n')
    assert load_sweep(sweep).out == Path("results/mine")


def test_summary_csv_cells_cannot_be_spreadsheet_formulas(tmp_path):
    import csv

    from suture_fem.studies.sweep import load_sweep
    from suture_fem.studies.sweep.summary import write_summary

    sweep = tmp_path / "s.toml"
    sweep.write_text('base = "paper"\n[grid]\n"solver.linear_solver" = ["=HYPERLINK(\\"http://x\\")", "@SUM(A1)", '
                     '"+1+cmd", "-2+3"]\n"loading.force_n" = [-1.5]\n')
    plan = load_sweep(sweep, out=tmp_path / "out")
    write_summary(plan)
    rows = list(csv.DictReader((tmp_path / "out" / "summary.csv").read_text().splitlines()))
    cells = [row["solver.linear_solver"] for row in rows]
    assert cells == ["'=HYPERLINK(\"http://x\")", "'@SUM(A1)", "'+1+cmd", "'-2+3"]
    assert {row["loading.force_n"] for row in rows} == {"-1.5"}  # numbers stay numbers


# ----------------------------------------------------------------------------- pictures, complete or absent

def test_an_interrupted_calibration_picture_keeps_the_old_one(tmp_path, monkeypatch):
    # calibration.png was written in place: a kill while drawing left a 0-byte file
    from matplotlib.figure import Figure

    from suture_fem.studies.calibrate.report import picture

    png = tmp_path / "calibration.png"
    png.write_bytes(b"\x89PNG complete picture of an earlier calibration")

    def interrupted(self, target, **kwargs):
        if isinstance(target, (str, Path)):
            open(target, "wb").close()  # matplotlib opens (truncates) the file, then the kill arrives
        raise KeyboardInterrupt

    monkeypatch.setattr(Figure, "savefig", interrupted)
    record = {"data": [{"quantity": "usum_mm", "force_n": 1.0, "value_mm": 1.0, "sd_mm": 0.1,
                        "resolution_mm": 0.1}], "curve": []}
    with pytest.raises(KeyboardInterrupt):
        picture(record, png)
    assert png.read_bytes() == b"\x89PNG complete picture of an earlier calibration"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["calibration.png"]


# ----------------------------------------------------------------------------- one run per folder

def test_a_second_run_into_the_same_folder_is_refused(tmp_path, capsys):
    import fcntl

    from suture_fem.support.io import this_process

    out = tmp_path / "run"
    out.mkdir()
    with open(out / ".run.lock", "w") as held:  # as the first run does, for its life
        fcntl.flock(held.fileno(), fcntl.LOCK_EX)
        held.write(json.dumps(this_process()))
        held.flush()
        code, err = _cli(["run", "paper", "--set", "mesh.degree=1", "--no-pictures", "--out", str(out)], capsys)
    (out / ".run.lock").unlink()
    assert code == 2 and len(err) == 1 and f"run folder {out} is in use by process {os.getpid()}" in err[0], err
    assert list(out.iterdir()) == []  # nothing solved, nothing written


# ----------------------------------------------------------------------------- a full disk under MPI

@pytest.mark.slow
@pytest.mark.mpi
@pytest.mark.parametrize("size_kib", [300, 450])
def test_fields_on_a_full_disk_under_mpi_end_in_one_line(size_kib, tmp_path):
    # mpirun -n 2 ... --fields: 450 KiB (full while writing a field): the one-line error, then both
    # ranks aborted in C++ ("Failed to close HDF5 file.", exit 134, up to 94 lines) from the XDMF file's
    # destructor; 300 KiB (full while writing the mesh): one rank failed, the other waited for ever
    point = tmp_path / "disk"
    point.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k", "tmpfs", str(point)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.strip()}")
    from tests.conftest import mpirun

    try:
        cmd = mpirun(2) + [sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", "--set", "mesh.degree=1",
                           "--set", "loading.force_n=1.0", "--fields", "--no-pictures", "--out", str(point / "o")]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(), cwd=tmp_path)
        ours = [line for line in proc.stderr.splitlines() if line.startswith("suture-fem: error:")]
        assert len(ours) == 1 and "fields.h5" in ours[0], proc.stderr
        assert "terminate called" not in proc.stderr and "Signal: Aborted" not in proc.stderr
        assert proc.returncode == 1, proc.stderr
        assert sorted(p.name for p in (point / "o").iterdir()) == ["results.json"]
        assert json.loads((point / "o" / "results.json").read_text())["status"] == "failed"
    finally:
        subprocess.run(["umount", "-l", str(point)], check=False)
