"""Every rank and child stops; the first screen tells the truth (docs/reliability.md, the last section).

The signal tests wait for a marker (results.json "running" with a converged step) before they signal,
and then only for the process to end (a generous timeout against a hang, no wall-clock limit).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.conftest import FAST, ROOT, mpi_env, mpirun, sets

#: A ramp of many small steps: long enough that a signal sent after its first step lands mid-ramp.
SLOW = ["mesh.degree=1", "mesh.refinement=0", "solver.max_step=0.05", "solver.initial_step=0.05"]
HANG_S = 600  # only against a hang: every process here ends within seconds of its signal


def _results(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _until(condition, proc: subprocess.Popen | None = None, what: str = "") -> None:
    """Poll ``condition`` until true (fails if ``proc`` ends first, or after HANG_S)."""
    t0 = time.monotonic()
    while not condition():
        if proc is not None and proc.poll() is not None:
            pytest.fail(f"the process ended (exit {proc.returncode}) before {what}")
        if time.monotonic() - t0 > HANG_S:
            pytest.fail(f"no {what} after {HANG_S} s")
        time.sleep(0.1)


def _stepping(path: Path):
    """results.json is "running" with at least one converged step."""
    def ready() -> bool:
        r = _results(path)
        return r is not None and r["status"] == "running" and len(r["force_displacement"]) > 1
    return ready


def _children(pid: int, word: str) -> list[int]:
    """The live processes whose parent is ``pid`` and whose command line contains ``word``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()
        if int(fields[1]) == pid and fields[0] != "Z" and word in cmdline:
            found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2:].split()[0] != "Z"


def _run(args: list[str], out: Path, ranks: int = 1) -> subprocess.Popen:
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", *args]
    return subprocess.Popen((mpirun(ranks) if ranks > 1 else []) + cmd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=mpi_env(), cwd=ROOT)


def _finish(proc: subprocess.Popen) -> tuple[str, str]:
    try:
        return proc.communicate(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"hung after the signal:\n{err[-3000:]}")


# ----------------------------------------------------------------------------- every rank stops

@pytest.mark.parametrize("signum, rank", [(signal.SIGINT, 1), (signal.SIGTERM, 0), (signal.SIGHUP, 1)])
def test_a_signal_to_one_rank_stops_every_rank(signum, rank, tmp_path):
    out = tmp_path / "run"
    proc = _run(["run", "paper", *sets(SLOW), "--no-pictures", "--out", str(out)], out, ranks=2)
    try:
        _until(_stepping(out / "results.json"), proc, "a converged step")
        root = _results(out / "results.json")["process"]["pid"]
        ranks = [root] + [p for p in _children(proc.pid, "suture_fem.cli") if p != root]
        assert len(ranks) == 2, ranks
        os.kill(ranks[rank], signum)
        _, err = _finish(proc)
    finally:
        proc.kill()
    name = signal.Signals(signum).name
    results = _results(out / "results.json")
    assert results["status"] == "interrupted" and name in results["error"], (results["status"], err[-2000:])
    assert proc.returncode == 128 + signum, err[-2000:]
    assert f"interrupted ({name})" in err and "Traceback" not in err and "MPI_ABORT" not in err


def test_sighup_ends_a_serial_run_like_sigterm(tmp_path):
    out = tmp_path / "run"
    proc = _run(["run", "paper", *sets(SLOW), "--no-pictures", "--out", str(out)], out)
    try:
        _until(_stepping(out / "results.json"), proc, "a converged step")
        proc.send_signal(signal.SIGHUP)
        _, err = _finish(proc)
    finally:
        proc.kill()
    results = _results(out / "results.json")
    assert (proc.returncode, results["status"]) == (129, "interrupted"), err[-2000:]
    assert "SIGHUP" in results["error"] and "interrupted (SIGHUP)" in err
    assert "MPI_ABORT" not in err and "Traceback" not in err


def test_a_burst_of_signals_is_reported_by_the_first(tmp_path):
    """Ctrl-C twice then SIGTERM, microseconds apart: one stop, named by the first, never "converged"."""
    out = tmp_path / "run"
    proc = _run(["run", "paper", *sets(SLOW), "--no-pictures", "--out", str(out)], out)
    try:
        _until(_stepping(out / "results.json"), proc, "a converged step")
        for signum in (signal.SIGINT, signal.SIGINT, signal.SIGTERM):
            os.kill(proc.pid, signum)
        _, err = _finish(proc)
    finally:
        proc.kill()
    results = _results(out / "results.json")
    assert (proc.returncode, results["status"]) == (130, "interrupted"), err[-2000:]
    assert "SIGINT" in results["error"] and "Traceback" not in err


def _signal_in_jacobian(monkeypatch, burst) -> None:
    """At the third Jacobian of the solve, ``burst()`` runs inside SNES's Jacobian callback."""
    from suture_fem.solve.newton import NewtonSolver

    calls = {"n": 0}
    jacobian = NewtonSolver._jacobian

    def patched(self, snes, x, A, P):
        calls["n"] += 1
        if calls["n"] == 3:
            burst()
        return jacobian(self, snes, x, A, P)

    monkeypatch.setattr(NewtonSolver, "_jacobian", patched)


def test_a_burst_inside_the_jacobian_callback_is_one_stop_named_by_the_first(tmp_path, monkeypatch, capsys):
    from suture_fem.cli import main

    def burst():  # all three pending at once on this thread, delivered when the callback unblocks them
        handled = {signal.SIGINT, signal.SIGTERM}
        signal.pthread_sigmask(signal.SIG_BLOCK, handled)
        try:
            for signum in (signal.SIGINT, signal.SIGINT, signal.SIGTERM):
                signal.pthread_kill(threading.get_ident(), signum)  # not to another thread of this process
        finally:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, handled)  # never left blocked: children would inherit it
        time.sleep(0.5)

    _signal_in_jacobian(monkeypatch, burst)
    out = tmp_path / "run"
    code = main(["run", "paper", *sets(FAST), "--no-pictures", "--out", str(out)])
    results = _results(out / "results.json")
    assert (code, results["status"]) == (130, "interrupted"), capsys.readouterr().err[-2000:]
    assert "SIGINT" in results["error"]


def test_a_signal_whose_exception_was_swallowed_still_stops_the_run(tmp_path, monkeypatch, capsys):
    """Compiled code that cannot pass an exception on prints it and goes on: the next check raises it again."""
    from suture_fem.cli import main

    def swallowed():
        try:
            signal.pthread_kill(threading.get_ident(), signal.SIGINT)  # raised here, inside the try
            time.sleep(0.5)
        except KeyboardInterrupt:
            pass

    _signal_in_jacobian(monkeypatch, swallowed)
    out = tmp_path / "run"
    code = main(["run", "paper", *sets(FAST), "--no-pictures", "--out", str(out)])
    results = _results(out / "results.json")
    assert (code, results["status"]) == (130, "interrupted"), capsys.readouterr().err[-2000:]


# ----------------------------------------------------------------------------- every child stops

def _after(pid: int, word: str) -> str:
    """The argument after ``word`` on the command line of process ``pid``."""
    args = Path(f"/proc/{pid}/cmdline").read_bytes().decode().split("\0")
    return args[args.index(word) + 1]


def _child_stops_with(parent: subprocess.Popen, word: str, folder_of, end_parent) -> dict:
    """Wait for the parent's child (``word`` in its command line) to step, end the parent; the child's results."""
    _until(lambda: bool(_children(parent.pid, word)), parent, f"a {word} child")
    child = _children(parent.pid, word)[0]
    results = folder_of(child) / "results.json"
    _until(_stepping(results), parent, "the child's first converged step")
    end_parent()
    _finish(parent)
    _until(lambda: not _alive(child), None, "the child's end")
    return _results(results)


def test_convergence_interrupted_stops_its_rung_process(tmp_path):
    out = tmp_path / "ledger"
    parent = _run(["convergence", "paper", *sets(SLOW), "--degrees", "1", "--refinements", "0,1", "--out", str(out)],
                  out)
    try:
        child = _child_stops_with(parent, "ledger-rung", lambda pid: Path(_after(pid, "--out")),
                                  lambda: parent.send_signal(signal.SIGINT))
    finally:
        parent.kill()
    assert parent.returncode == 130
    assert child["status"] == "interrupted" and "SIGTERM" in child["error"], child["status"]


def test_reproduce_killed_outright_ends_its_ramp_process(tmp_path):
    out = tmp_path / "reproduce"
    parent = _run(["reproduce", "--out", str(out), "--calibrate", "none", "--jobs", "2", "--no-pictures",
                   "--mesh", "scene", *sets(SLOW)], out)
    try:
        child = _child_stops_with(parent, "reproduce-ramp", lambda pid: Path(_after(pid, "reproduce-ramp")).parent,
                                  parent.kill)
    finally:
        parent.kill()
    assert parent.returncode == -signal.SIGKILL
    assert child["status"] == "interrupted" and "SIGTERM" in child["error"], child["status"]


# ----------------------------------------------------------------------------- the study's exit code

def _study(reached_n: dict[int, float]):
    """What ``reproduce`` returns when the ramp of each cone count in ``reached_n`` stopped at that force.

    The study's own comparison, findings and missing values on ramps made up here (the real study's
    ramps take minutes): each reported force up to where the ramp stopped has a record.
    """
    from suture_fem.pipeline import load_scene
    from suture_fem.studies.paper import CONES, FORCES_N
    from suture_fem.studies.reproduce.calibration import not_calibrated
    from suture_fem.studies.reproduce.compare import comparison, findings, missing_values

    scene = load_scene("paper_reproduction", [])

    def record(n, f):
        return {"force_n": f, "usum_mm": 8.0 * f / n, "regions": {"tissue": {"seqv_pa": 2e5 * f, "eptoeqv": 0.5 * f}}}

    results = {n: {"at_forces": [record(n, f) for f in FORCES_N if f <= reached_n.get(n, 4.0)]} for n in CONES}
    stopped = {n: f"solve stopped (gent_limit) at {f:.3g} N" for n, f in reached_n.items()}
    cmp = comparison(results, not_calibrated(scene), scene)
    cmp.update({"stopped": stopped, "findings": findings(stopped, cmp["rows"]), "missing": missing_values(cmp["rows"]),
                "run": {"wall_time_s": 1.0, "cpu_time_s": 1.0, "jobs": 1, "ramps_cpu_time_s": 1.0}})
    return lambda *args, **kwargs: cmp


@pytest.mark.parametrize("reached, code, words", [
    ({1: 1.94, 2: 3.96}, 0, ["finding: 1 cone(s): solve stopped (gent_limit) at 1.94 N (past every value the paper "
                             "gives for it)", "finding: 2 cone(s)"]),
    ({4: 2.5}, 3, ["finding: 4 cone(s)", "missing: Table 1 usum_mm, 4 cone(s) at 3 N"]),
])
def test_reproduce_exits_0_when_every_paper_value_is_solved(reached, code, words, tmp_path, monkeypatch, capsys):
    import suture_fem.cli.reproduce as command
    from suture_fem.cli import main

    monkeypatch.setattr(command, "reproduce", _study(reached))
    assert main(["reproduce", "--out", str(tmp_path / "r"), "--calibrate", "none"]) == code
    printed = capsys.readouterr().out
    for w in words:
        assert w in printed, printed


# ----------------------------------------------------------------------------- the run's first screen

def test_the_run_summary_leads_with_the_converged_tissue_measures(tmp_path, capsys):
    from suture_fem.cli import main
    from suture_fem.cli.run_report import summary

    out = tmp_path / "run"
    assert main(["run", "paper", *sets(FAST), "--no-pictures", "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    results = _results(out / "results.json")
    rec = results["at_forces"][-1]
    tissue = rec["regions"]["tissue"]
    at = next(i for i, line in enumerate(printed) if line.startswith(f"  F = {rec['force_n']:g} N:"))
    lead, peak = printed[at + 1], printed[at + 2]
    assert lead.strip().startswith("tissue, critical distance 0.1 mm: SEQV") and "EPTOEQV" in lead
    assert f"SEQV {tissue['seqv_cd_pa'] / 1e6:.4g} MPa" in lead and f"EPTOEQV {tissue['eptoeqv_cd']:.4g}" in lead
    assert peak.strip().startswith("tissue peak") and "mesh-dependent" in peak
    assert f"SEQV {tissue['seqv_pa'] / 1e6:.4g} MPa" in peak
    assert "error bars: run with --error-estimate" in printed[1]
    # with --error-estimate's record, each converged measure carries its estimated error
    results["error_estimate"] = {"at_forces": [{"force_n": rec["force_n"],
                                                "regions.tissue.seqv_cd_pa": {"plus_minus": 2.1e4},
                                                "regions.tissue.eptoeqv_cd": {"plus_minus": 0.012}}]}
    text = summary(results, out, [])
    assert f"SEQV {tissue['seqv_cd_pa'] / 1e6:.4g} +- 0.021 MPa" in text and "+- 0.012 at" in text


# ----------------------------------------------------------------------------- the set-up's first screen

def _install(tmp_path: Path, **env: str) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(ROOT / "scripts" / "install.sh")], capture_output=True, text=True,
                          env={**os.environ, "SUTURE_FEM_INSTALL_LOG": str(tmp_path / "install.log"), **env},
                          timeout=HANG_S)


def test_a_failing_set_up_stage_is_one_line_and_names_its_full_log(tmp_path):
    proc = _install(tmp_path, SUTURE_FEM_VENV="/proc/no-such-folder/venv")
    assert proc.returncode != 0
    assert proc.stdout.splitlines()[-1].endswith("... failed (exit 1)"), proc.stdout
    assert f"the full log is {tmp_path / 'install.log'}" in proc.stderr
    assert "No such file or directory: '/proc/no-such-folder'" in (tmp_path / "install.log").read_text()


def test_the_set_up_prints_one_line_per_stage(tmp_path):
    proc = _install(tmp_path)  # everything is installed already: the pip and kernel stages run again
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert all(line.startswith("install.sh: ") for line in lines) and len(lines) <= 6 and not proc.stderr, proc
    assert lines[-1].startswith("install.sh: ready") and str(tmp_path / "install.log") in lines[-1]
    assert "pip install" in (tmp_path / "install.log").read_text()
