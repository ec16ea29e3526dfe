"""`suture-fem sweep --slurm` without a cluster: its options are checked before anything is submitted or
written, and the batch script quotes every word a sweep file or the command line gives it."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest

from suture_fem.cli.main import main
from suture_fem.studies.sweep import Sweep, SweepError
from suture_fem.studies.sweep.slurm import (
    SlurmOptions,
    check_options,
    check_sbatch_options,
    read_sbatch_file,
    summary_script,
    task_script,
)

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("tokens", [["--mem=2G"], ["--account", "proj"], ["-A", "proj"], ["-Aproj"], ["--exclusive"],
                                    ["--mem-per-cpu=2G", "--qos=low", "--constraint", "a&b"], ["--job-name=mine"]])
def test_ordinary_sbatch_options_pass(tokens):
    assert check_sbatch_options(tokens, "--sbatch") == tokens


@pytest.mark.parametrize(("tokens", "named"), [
    (["--array=1-3"], "--array"), (["-a", "1"], "-a"), (["--wrap=rm -rf ~"], "--wrap"), (["--output=x"], "--output"),
    (["-p", "big"], "-p"), (["--time=10"], "--time"), (["-n4"], "-n"),
    (["; touch /tmp/x"], "is not an sbatch option"), (["proj"], "is not an sbatch option"),
    (["--mem=1G\nsrun x"], "control characters"), (["--Mem=1G"], "lower-case"),
    (["--account", "a", "b"], "is not an sbatch option"),
])
def test_bad_or_reserved_sbatch_options_are_refused(tokens, named):
    with pytest.raises(SweepError, match=named):
        check_sbatch_options(tokens, "--sbatch")


def test_an_options_file_reads_sbatch_headers_and_skips_comments(tmp_path):
    path = tmp_path / "opts"
    path.write_text("#SBATCH --mem-per-cpu=2G\n# a comment\n\n--account=proj --qos 'low prio'\n")
    assert read_sbatch_file(str(path)) == ["--mem-per-cpu=2G", "--account=proj", "--qos", "low prio"]
    path.write_text("#SBATCH --wrap='sh -c x'\n")
    with pytest.raises(SweepError, match="--wrap"):
        read_sbatch_file(str(path))


@pytest.mark.parametrize(("opts", "named"), [
    (SlurmOptions(time="abc"), "--time"), (SlurmOptions(time="1:2:3:4"), "--time"),
    (SlurmOptions(partition="a;b"), "--partition"), (SlurmOptions(ranks_per_scene=0), "--ranks-per-scene"),
    (SlurmOptions(mpi="pmix;id"), "--mpi"), (SlurmOptions(max_running=0), "--max-running"),
])
def test_bad_options_are_refused(opts, named):
    with pytest.raises(SweepError, match=named):
        check_options(opts)


@pytest.mark.parametrize("time", ["30", "1:30:00", "2-12", "1-00:30:00", "UNLIMITED"])
def test_slurm_time_formats_pass(time):
    assert check_options(SlurmOptions(time=time, partition="gpu,cpu")).time == time


@pytest.mark.parametrize("bad", [["--time", "soon"], ["--sbatch=--array=0-9"], ["--sbatch=--mem=1G; rm -rf ~"],
                                 ["--sbatch=--qos 'open"], ["--partition", "$(id)"], ["--status"]])
def test_the_command_line_exits_2_in_one_line_before_writing(bad, tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["sweep", str(ROOT / "examples" / "cone_study.toml"), "--out", str(out), "--slurm", *bad])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and err.startswith("suture-fem: error: "), err
    assert not out.exists()


def test_the_batch_script_quotes_what_a_sweep_file_names(tmp_path):
    sweep = Sweep(path=tmp_path / "a $(touch x); b.toml", base="paper", out=tmp_path / "o`id`; rm -rf ~", cases=[])
    script = task_script(sweep, SlurmOptions(), ["--set", "notes.text=\"'$(id)'\""])
    lines = script.splitlines()
    assert lines[0] == "#!/bin/sh" and lines[-1].startswith("exec srun --mpi=pmix ")
    words = shlex.split(lines[-1])
    assert words[3:9] == [sys.executable, "-P", "-m", "suture_fem.cli", "sweep", str(sweep.path.resolve())]
    assert words[9:13] == ["--out", str(sweep.out.resolve()), "--set", "notes.text=\"'$(id)'\""]
    assert words[-2:] == ["--slurm-task", "$SLURM_ARRAY_TASK_ID"]
    summary = shlex.split(summary_script(sweep, []).splitlines()[-1])
    assert summary[-3:] == ["--out", str(sweep.out.resolve()), "--summary-only"]


def test_tasks_and_a_local_sweep_exclude_each_other(tmp_path):
    from suture_fem.studies.sweep.folders import (
        release_lock,
        release_task_locks,
        scene_busy,
        take_lock,
        take_task_locks,
    )

    out = tmp_path / "out"
    locks = take_task_locks(out, "001-abc")
    assert scene_busy(out, "001-abc") and not scene_busy(out, "000-def")
    other = take_task_locks(out, "000-def")  # tasks of other scenes run side by side
    with pytest.raises(SweepError, match="001-abc is being solved by another task"):
        take_task_locks(out, "001-abc")
    with pytest.raises(SweepError, match="in use"):
        take_lock(out)  # a local sweep waits for the tasks
    release_task_locks(out, "001-abc", locks)
    release_task_locks(out, "000-def", other)
    assert not scene_busy(out, "001-abc") and not (out / ".001-abc.lock").exists()
    held = take_lock(out)
    with pytest.raises(SweepError, match="not a Slurm task"):
        take_task_locks(out, "001-abc")  # and the tasks for a local sweep
    release_lock(held, out)


def test_status_reads_the_folders_without_a_cluster(tmp_path, capsys, monkeypatch):
    from suture_fem.studies.sweep import load_sweep
    from suture_fem.support.io import write_json

    monkeypatch.setenv("PATH", str(tmp_path))  # no squeue, no sbatch
    path = tmp_path / "s.toml"
    path.write_text('base = "paper"\n[grid]\n"geometry.cones" = [1, 2, 3]\n')
    out = tmp_path / "out"
    names = [c.name for c in load_sweep(path, [], out).cases]
    write_json(out / names[1] / "status.json", {"status": "converged"})
    assert main(["sweep", str(path), "--out", str(out), "--status"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[:2] for line in lines[:3]] == [[names[0], "pending"], [names[1], "converged"],
                                                        [names[2], "pending"]]
    assert "3 scenes: 1 converged, 2 pending" in lines[3]
    assert main(["sweep", str(path), "--out", str(out), "--slurm"]) == 1  # no sbatch: one line, nothing written
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sbatch not found" in err[0]
    assert sorted(p.name for p in out.iterdir()) == [names[1]]
