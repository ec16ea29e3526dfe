""""Converged" means balanced; bad input is one line, exit 2, before any work or folder.

docs/reliability.md ("Converged means balanced; bad input before any work") lists every case with its
command, what is expected and what was observed. Scene-level cases call the scene reader; command-line
cases run ``suture-fem`` in this process (or under mpirun) and check the exit code, the one line and
that no output folder was made. One case solves (a 0.5 N pull on one cone at degree 1).
"""

from __future__ import annotations

import dataclasses
import os
import shutil
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from suture_fem.scene.load import parse_scene
from suture_fem.support.errors import SceneError

ONE_CONE = ["geometry.cones=1", "mesh.degree=1", "mesh.refinement=0"]


def _error(overrides, source="paper"):
    with pytest.raises(SceneError) as err:
        parse_scene(source, list(overrides))
    message = str(err.value)
    assert "\n" not in message
    return message


def _cli(args, capsys):
    """``suture-fem ARGS`` in this process: (exit code, its error lines, stderr); no traceback allowed."""
    from suture_fem.cli.main import main

    code = main(list(args))
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, [line for line in err.splitlines() if line.startswith("suture-fem: error:")], err


# ----------------------------------------------------------------------------- converged means balanced

@pytest.mark.parametrize("overrides, words", [
    (["loading.force_n=0.5", "solver.atol=1"], ["solver.atol", "<= 5e-07 N"]),
    (["solver.petsc_options.snes_atol=0.5"], ["snes_atol", "<= 4e-06 N"]),
    (["solver.rtol=0.5"], ["solver.rtol", "<= 1e-06"]),
    (["solver.petsc_options.snes_rtol=0.9"], ["snes_rtol", "<= 1e-06"]),
    (["loading.force_n=1e-300"], ["loading.force_n", ">= 1e-06"]),
    (["loading.force_scale=1e-300"], ["force_scale", "at least 1e-06 N"]),
    (["loading.report_forces_n=[1e-13, 1.0]"], ["report_forces_n", ">= 1e-06"]),
])
def test_tolerances_and_pulls_that_cannot_be_balanced_are_refused(overrides, words):
    message = _error(overrides)
    assert all(w in message for w in words), message


def test_a_newton_tolerance_above_the_balance_does_not_end_converged_unbalanced():
    """A solver section built past the checks (atol = 1 N on a 0.5 N pull) still balances every state."""
    from mpi4py import MPI

    from suture_fem.pipeline import load_scene, run_scene
    from suture_fem.scene.schema import SolverSection
    from suture_fem.studies.hardcases import BALANCE_TOL  # 1e-6 of the pull

    scene = load_scene("paper", [*ONE_CONE, "loading.force_n=0.5", "loading.report_forces_n=[]"])
    loose = dataclasses.replace(scene, solver=SolverSection.internal(**{**scene.solver.as_dict(), "atol": 1.0}))
    results = run_scene(loose, None, MPI.COMM_SELF)
    assert results["status"] == "converged"
    assert results["force_balance_rel"] < BALANCE_TOL  # was 0.97: USUM 0.743 mm instead of 3.10 mm


@pytest.mark.parametrize("overrides, words", [
    (["solver.min_step=1e-300", "solver.initial_step=1e-300", "solver.max_step=1e-300"], ["step = 1e-300", ">= 1e-09"]),
    (["solver.min_step=1e-9", "solver.initial_step=1e-9", "solver.max_step=1e-9"], ["1e+09 steps", "max_step"]),
    (["effects.inertia=true", "effects.time_step_s=1e-9"], ["1.2e+09 steps", "time_step_s", "years"]),
])
def test_a_path_that_cannot_finish_is_refused_before_meshing(overrides, words):
    message = _error(overrides)
    assert all(w in message for w in words), message


def test_maxload_tolerance_below_the_step_resolution_is_refused():
    from suture_fem.pipeline import load_scene
    from suture_fem.studies.maxload import search_scene

    scene = load_scene("paper", [])
    with pytest.raises(SceneError, match="--tol"):
        search_scene(scene, 4.0, 1e-300)


def test_maxload_bracket_wider_than_the_tolerance_is_not_called_bracketed(tmp_path, monkeypatch):
    import suture_fem.pipeline
    from suture_fem.pipeline import load_scene
    from suture_fem.studies.maxload import max_load
    from suture_fem.support.errors import SolveStopped, StopCause

    def futile(*args, **kwargs):  # the cutbacks gave up 0.0375 N short of the failing force
        raise SolveStopped(StopCause.GENT_LIMIT, 1.0, 1.0375, "6 cutbacks in a row at this load")

    monkeypatch.setattr(suture_fem.pipeline, "run_scene", futile)
    rec = max_load(load_scene("paper", []), None, 4.0, 0.01, None)
    assert rec["limit"] == "physical" and rec["width_n"] == pytest.approx(0.0375)
    assert not rec["bracketed"] and not rec["tolerance_met"]
    assert "0.0375 N wide" in rec["note"]


def _verdict(theta, J, lo=0.2, hi=5.0):
    from suture_fem.studies.calibrate.data import THREAD_END, Point
    from suture_fem.studies.calibrate.fit import uncertainty
    from suture_fem.studies.calibrate.keys import FitKey

    points = [Point(f, 1.0, None, 0.01, THREAD_END) for f in (0.5, 1.0, 1.5)]
    key = FitKey("materials.tissue_scale", lo, hi, 1.0, "direct")
    r = np.array([0.01, -0.02, 0.01])
    return uncertainty([key], points, np.array([theta]), r, np.array(J), np.ones(3), "residual variance")


def test_a_fit_pinned_at_a_bound_is_not_called_determined():
    rec = _verdict(0.2, [[-1.0], [-2.0], [-3.0]])  # at its lower bound, sensitive to it
    ident = rec["identifiability"]
    assert not ident["identifiable"] and "bound" in ident["verdict"]
    assert "determined by the data" not in ident["verdict"]


def test_a_fit_known_only_within_a_wide_interval_is_not_called_determined():
    rec = _verdict(1.0, [[-1e-3], [-2e-3], [-3e-3]])  # an interval of several times the value
    ident = rec["identifiability"]
    lo, hi = rec["parameters"]["materials.tissue_scale"]["ci95"]
    assert hi - lo > 1.0
    assert not ident["identifiable"] and ident["verdict"].startswith("NOT determined")


# ----------------------------------------------------------------------------- bad input before any work

def test_petsc_lu_under_mpi_is_one_line_before_any_folder(tmp_path):
    out = tmp_path / "o"
    mpirun = shutil.which("mpirun") or shutil.which("mpiexec")
    assert mpirun is not None, "scripts/install.sh installs openmpi-bin"
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1"}
    done = subprocess.run([mpirun, "-n", "2", sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", "--set",
                           'solver.linear_solver="petsc"', "--out", str(out)], capture_output=True, text=True, env=env)
    errors = [line for line in done.stderr.splitlines() if line.startswith("suture-fem: error:")]
    assert done.returncode != 0 and "PETSC ERROR" not in done.stderr, done.stderr[-2000:]
    assert len(errors) == 1 and "solver.linear_solver" in errors[0] and "mumps" in errors[0], done.stderr[-2000:]
    assert not out.exists()


def test_a_dotted_key_thousands_deep_is_one_line(tmp_path, capsys):
    key = ".".join(["a"] * 3000)
    code, errors, _ = _cli(["show", "paper", "--set", f"{key}=1"], capsys)
    assert code == 2 and len(errors) == 1 and "3000 dotted parts" in errors[0]
    sweep = tmp_path / "s.toml"
    sweep.write_text(f'base = "paper"\n[grid]\n"{key}" = [1]\n')
    code, errors, _ = _cli(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--list"], capsys)
    assert code == 2 and len(errors) == 1 and "grid key" in errors[0] and len(errors[0]) < 400
    assert not (tmp_path / "o").exists()


class _Fifo:
    """A FIFO whose writer sends ``text`` to the first reader (old code read it as a file)."""

    def __init__(self, path: Path, text: str):
        self.path = path
        os.mkfifo(path)
        self.thread = threading.Thread(target=self._write, args=(text,), daemon=True)
        self.thread.start()

    def _write(self, text: str) -> None:
        try:
            with open(self.path, "w") as f:
                f.write(text)
        except OSError:
            pass

    def close(self) -> None:
        fd = os.open(self.path, os.O_RDONLY | os.O_NONBLOCK)  # releases a writer still waiting for a reader
        self.thread.join()
        os.close(fd)


@pytest.mark.parametrize("kind", ["scene", "data"])
def test_a_device_or_fifo_is_refused_unread(kind, tmp_path, capsys):
    if kind == "scene":
        code, errors, _ = _cli(["show", "/dev/null"], capsys)  # old: an empty scene; /dev/zero filled memory
        assert code == 2 and len(errors) == 1 and "not a regular file" in errors[0], errors
        return
    fifo = _Fifo(tmp_path / "f.csv", "0.5,1.0\n")  # old: read what the writer sent (with no writer: a hang)
    try:
        from suture_fem.studies.calibrate.data import DataError, read_csv

        with pytest.raises(DataError, match="not a regular file"):
            read_csv(fifo.path)
    finally:
        fifo.close()


def test_a_sweep_file_that_is_a_fifo_is_refused(tmp_path):
    from suture_fem.studies.sweep import load_sweep
    from suture_fem.studies.sweep.plan import SweepError

    fifo = _Fifo(tmp_path / "s.toml", 'base = "paper"\n[grid]\n"geometry.cones" = [1]\n')
    try:
        with pytest.raises(SweepError, match="not a regular file"):
            load_sweep(fifo.path)
    finally:
        fifo.close()


@pytest.mark.parametrize("command", [
    ["mesh", "paper", "--out", "{file}/m.msh"],
    ["convergence", "paper", "--out", "{file}/c"],
    ["calibrate", "paper", "--data", "paper", "--fit", "materials.tissue_scale", "--out", "{file}/k"],
    ["reproduce", "--out", "{file}/r"],
])
def test_an_unusable_out_is_refused_before_any_work(command, tmp_path, capsys):
    file = tmp_path / "afile"
    file.write_text("")
    code, errors, err = _cli([a.format(file=file) for a in command], capsys)
    assert code == 2 and len(errors) == 1 and "is a file, not a folder" in errors[0], err
    assert "calibration:" not in err  # nothing was solved first


def test_calibrate_with_no_evaluations_is_refused(tmp_path, capsys):
    out = tmp_path / "k"
    code, errors, _ = _cli(["calibrate", "paper", "--data", "paper", "--fit", "materials.tissue_scale",
                            "--max-evaluations", "0", "--out", str(out)], capsys)
    assert code == 2 and len(errors) == 1 and "--max-evaluations 0" in errors[0]
    assert not out.exists()


def _curve(tmp_path, text, name="c.csv"):
    from suture_fem.studies.calibrate.data import read_csv

    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return [(p.force_n, p.value_mm, p.sd_mm) for p in read_csv(path)]


def test_a_curve_with_a_byte_order_mark_keeps_its_first_row(tmp_path):
    assert _curve(tmp_path, "\ufeff0.5,1.0\n1.0,2.0\n") == [(0.5, 1.0, None), (1.0, 2.0, None)]


def test_a_curve_header_names_its_columns(tmp_path):
    assert _curve(tmp_path, "displacement_mm,force_n\n1.0,0.5\n2.0,1.0\n") == [(0.5, 1.0, None), (1.0, 2.0, None)]
    assert _curve(tmp_path, "force_n,sd_mm,displacement_mm\n0.5,0.1,1.0\n") == [(0.5, 1.0, 0.1)]
    from suture_fem.studies.calibrate.data import DataError

    with pytest.raises(DataError, match="header"):
        _curve(tmp_path, "force,stretch\n0.5,1.0\n")


@pytest.mark.parametrize("text, words", [
    ("0.5," + "1" * 200_000 + "\n", "row 1: field larger than field limit"),
    ("".join(f"{0.01 * (i + 1):.2f},{i}\n" for i in range(201)), "more than 200 data rows"),
    ("".join(f"{0.001 * (i + 1):.3f},{i}\n" for i in range(100_000)), "larger than 1024 KiB"),
])
def test_a_curve_too_big_to_fit_is_one_line(tmp_path, text, words):
    from suture_fem.studies.calibrate.data import DataError

    with pytest.raises(DataError) as err:
        _curve(tmp_path, text)
    assert words in str(err.value) and len(str(err.value)) < 300


def test_sweep_ranks_per_scene_below_one_makes_no_folder(tmp_path, capsys):
    sweep = tmp_path / "s.toml"
    sweep.write_text('base = "paper"\n[grid]\n"geometry.cones" = [1]\n')
    code, errors, _ = _cli(["sweep", str(sweep), "--out", str(tmp_path / "o"), "--ranks-per-scene", "-1"], capsys)
    assert code == 2 and len(errors) == 1 and "--ranks-per-scene -1" in errors[0]
    assert not (tmp_path / "o").exists()


def test_control_characters_in_a_key_never_reach_the_terminal(capsys):
    code, errors, err = _cli(["show", "paper", "--set", "sol\x1b[31mver.x=1"], capsys)
    assert code == 2 and len(errors) == 1 and "\\x1b[31m" in errors[0]
    assert "\x1b" not in err


def test_a_huge_value_is_not_echoed_whole(tmp_path, capsys):
    scene = tmp_path / "big.toml"
    scene.write_text('[solver]\natol = "' + "x" * 1_000_000 + '"\n')
    code, errors, err = _cli(["show", str(scene)], capsys)
    assert code == 2 and len(errors) == 1 and "1,000,002 characters" in errors[0]
    assert len(err) < 2000


def test_an_interrupted_show_does_not_speak_of_results(monkeypatch, capsys):
    import suture_fem.pipeline
    from suture_fem.support.errors import Interrupted

    def interrupted(*args, **kwargs):
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(suture_fem.pipeline, "load_scene", interrupted)
    code, _, err = _cli(["show", "paper"], capsys)
    assert code == 130 and "interrupted (SIGINT)" in err and "results.json" not in err
