"""Sweeps and one scene through a real Slurm cluster (scripts/slurm-local.sh up; `.ci/run` does it).

A small sweep submitted with `suture-fem sweep --slurm` gives every scene the same results.json as
the same sweep solved locally; a task cancelled while it solves leaves its scene pending, and
submitting again solves that scene alone. One scene under `srun -n 2 --mpi=pmix`, and one scene as
an array task of 2 ranks (--ranks-per-scene 2), agree with the serial solve. Without a reachable
cluster these tests skip, unless SUTURE_SLURM_REQUIRED=1 (set by scripts/test-slurm.sh after
bringing the cluster up), where they fail.

The tests share one sweep folder and run in file order.
"""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import time
from pathlib import Path

import pytest

from suture_fem.studies.sweep.folders import scene_busy
from tests.conftest import PYTHON, ROOT, cli, mpi_env, sets
from tests.mpi.conftest import SCENE
from tests.mpi.test_parallel import assert_same_state

pytestmark = [pytest.mark.mpi, pytest.mark.slurm]

SWEEP = """
base = "paper"
[set]
{common}
[[scenes]]
"geometry.cones" = 1
[[scenes]]
"geometry.cones" = 2
[[scenes]]                      # cancelled while it solves: many small load steps keep it solving long enough
"geometry.cones" = 4
solver = {{initial_step = 0.02, max_step = 0.02}}
"""
#: The scene whose task is cancelled while it solves.
CANCELLED = 2
#: results.json keys that describe the process, not the solution.
PROCESS_KEYS = ("process", "wall_time_s", "timings_s")
#: An upper bound on waiting for the queue to empty, so a broken cluster fails instead of hanging.
QUEUE_BOUND_S = 1800.0


def _cluster_up() -> None:
    sinfo = shutil.which("sinfo")
    proc = subprocess.run([sinfo, "-h", "-o", "%t"], capture_output=True, text=True) if sinfo else None
    if proc is not None and proc.returncode == 0 and {"idle", "mix", "alloc"} & set(proc.stdout.split()):
        return
    why = "sinfo not found" if proc is None else (proc.stderr.strip() or f"node state {proc.stdout.strip()!r}")
    message = f"no Slurm cluster reachable ({why}); scripts/slurm-local.sh up starts one"
    if os.environ.get("SUTURE_SLURM_REQUIRED") == "1":
        pytest.fail(message)
    pytest.skip(message)


def queue(jobs: list[str]) -> dict[str, str]:
    """Task id -> state of the given jobs still in Slurm's queue."""
    proc = subprocess.run(["squeue", "-h", "-r", "-j", ",".join(jobs), "-o", "%i %T"], capture_output=True, text=True)
    return dict(line.split() for line in proc.stdout.splitlines() if line.strip())


def wait_until_gone(jobs: list[str]) -> None:
    t0 = time.monotonic()
    while queue(jobs):
        assert time.monotonic() - t0 < QUEUE_BOUND_S, f"jobs {jobs} still queued: {queue(jobs)}"
        time.sleep(1.0)


def sweep_cli(*args: str) -> subprocess.CompletedProcess:
    proc = cli(["sweep", *args], timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc


def statuses(out: Path) -> dict[str, str]:
    lines = [line.split() for line in sweep_cli(str(out.parent / "study.toml"), "--out", str(out), "--status")
             .stdout.splitlines() if not line.startswith("suture-fem")]
    return {words[0]: words[1] for words in lines}


def jobs_of(out: Path) -> list[dict]:
    return json.loads((out / "slurm" / "jobs.json").read_text())


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """The sweep file, its Slurm folder and the same sweep solved locally (started in the background)."""
    _cluster_up()
    root = tmp_path_factory.mktemp("slurm")
    common = "\n".join(f'"{k}" = {v}' for k, v in (s.split("=", 1) for s in SCENE))
    path = root / "study.toml"
    path.write_text(SWEEP.format(common=common))
    local = subprocess.Popen([PYTHON, "-P", "-m", "suture_fem.cli", "sweep", str(path), "--out", str(root / "local")],
                             cwd=ROOT, env=mpi_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    yield path, root / "out", local
    if local.poll() is None:
        local.kill()
        local.wait()


def test_a_cancelled_task_leaves_its_scene_pending(study):
    path, out, _ = study
    submitted = sweep_cli(str(path), "--out", str(out), "--slurm", "--time", "30", "--sbatch=--mem=1G")
    assert "submitted 3 of 3 scenes" in submitted.stdout
    record = jobs_of(out)[-1]
    job, names = record["array_job"], record["scenes"]
    victim = names[str(CANCELLED)]
    t0 = time.monotonic()
    while not (out / f".{victim}.partial").exists():  # its task has started solving
        assert time.monotonic() - t0 < QUEUE_BOUND_S, queue([job])
        time.sleep(0.2)
    assert scene_busy(out, victim)  # what --status shows as "running"
    subprocess.run(["scancel", f"{job}_{CANCELLED}"], check=True)
    wait_until_gone([job, record["summary_job"]])
    found = statuses(out)
    assert found[victim] == "pending"
    assert [s for n, s in found.items() if n != victim] == ["converged", "converged"]
    assert not (out / victim).exists()
    with open(out / "summary.csv", newline="") as f:  # the summary job ran after the array, cancelled task included
        rows = {r["name"]: r["status"] for r in csv.DictReader(f)}
    assert rows[victim] == "pending"


def test_resubmitting_solves_the_cancelled_scene_alone(study):
    path, out, _ = study
    first = jobs_of(out)[-1]
    victim = first["scenes"][str(CANCELLED)]
    proc = sweep_cli(str(path), "--out", str(out), "--slurm", "--time", "30")
    assert "submitted 1 of 3 scenes" in proc.stdout
    record = jobs_of(out)[-1]
    assert record["scenes"] == {str(CANCELLED): victim}
    wait_until_gone([record["array_job"], record["summary_job"]])
    assert set(statuses(out).values()) == {"converged"}
    for name in first["scenes"].values():
        status = json.loads((out / name / "status.json").read_text())
        assert status["solve_count"] == 1 and status["ranks"] == 1, status
    again = sweep_cli(str(path), "--out", str(out), "--slurm")
    assert "nothing to submit" in again.stdout and len(jobs_of(out)) == 2


def test_every_scene_equals_the_local_sweep(study):
    path, out, local = study
    _, err = local.communicate(timeout=1200)
    assert local.returncode == 0, err
    names = sorted(p.name for p in out.iterdir() if (p / "results.json").exists())
    assert len(names) == 3 and names == sorted(p.parent.name for p in (out.parent / "local").glob("*/results.json"))
    for name in names:
        a = json.loads((out / name / "results.json").read_text())
        b = json.loads((out.parent / "local" / name / "results.json").read_text())
        for key in PROCESS_KEYS:
            a.pop(key), b.pop(key)
        assert a == b, name  # the same code on one rank: the same numbers, bit for bit


def test_one_scene_on_two_ranks_under_srun(tmp_path, serial_run):
    _cluster_up()
    cmd = ["srun", "-n", "2", "--mpi=pmix", PYTHON, "-P", "-m", "suture_fem.cli", "run", "paper", *sets(SCENE),
           "--out", str(tmp_path), "--no-pictures"]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(), cwd=ROOT, timeout=900)
    assert proc.returncode == 0, proc.stderr
    result = json.loads((tmp_path / "results.json").read_text())
    assert result["mpi_ranks"] == 2
    assert_same_state(serial_run, result)


def test_a_scene_of_two_ranks_as_an_array_task(tmp_path, serial_run):
    _cluster_up()
    path = tmp_path / "one.toml"
    scene = "\n".join(f'"{k}" = {v}' for k, v in (s.split("=", 1) for s in SCENE))
    path.write_text(f'base = "paper"\n[[scenes]]\n{scene}\n')
    out = tmp_path / "out"
    sweep_cli(str(path), "--out", str(out), "--slurm", "--ranks-per-scene", "2", "--time", "30")
    record = jobs_of(out)[-1]
    wait_until_gone([record["array_job"], record["summary_job"]])
    (name,) = record["scenes"].values()
    status = json.loads((out / name / "status.json").read_text())
    assert status["status"] == "converged" and status["ranks"] == 2, status
    result = json.loads((out / name / "results.json").read_text())
    assert result["mpi_ranks"] == 2
    assert_same_state(serial_run, result)
