"""`suture-fem sweep` under mpirun -n 2: two groups of one rank, bad scenes recorded, resume solves
nothing twice, --redo failed and --summary-only.

The tests share one sweep folder and run in file order (each one continues the previous one's sweep).
"""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest

from tests.conftest import cli
from tests.mpi.conftest import SCENE
from tests.mpi.test_parallel import assert_same_state

pytestmark = pytest.mark.mpi

SWEEP = """
base = "paper"
[set]
{common}
[[scenes]]
"geometry.cones" = 4             # the reference scene (serial_run)
[[scenes]]
"geometry.cones" = 1
[[scenes]]
geometry.cones = -1              # bad input: recorded as invalid
[[scenes]]
"geometry.cones" = 2
[[scenes]]                       # a solve that stops: one Newton iteration allowed, large minimum step
"geometry.cones" = 0
solver = {{max_iterations = 1, easy_iterations = 1, min_step = 0.05}}
"""
EXPECTED = ["converged", "converged", "invalid", "converged", "stopped"]


def statuses(out: Path) -> dict[str, dict]:
    return {p.parent.name: json.loads(p.read_text()) for p in sorted(out.glob("*/status.json"))}


def snapshot(out: Path) -> dict[str, tuple[int, bytes]]:
    """(mtime_ns, bytes) of every file in the scene folders."""
    return {str(p.relative_to(out)): (p.stat().st_mtime_ns, p.read_bytes())
            for p in sorted(out.glob("*/*")) if p.is_file() and not p.parent.name.startswith(".")}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("sweep")
    common = "\n".join(f'"{k}" = {v}' for k, v in (s.split("=", 1) for s in SCENE))
    path = root / "study.toml"
    path.write_text(SWEEP.format(common=common))
    out = root / "out"
    proc = cli(["sweep", str(path), "--out", str(out), "--ranks-per-scene", "1"], ranks=2, timeout=600)
    return path, out, proc


def test_two_groups_solve_every_good_scene_and_record_the_bad_ones(sweep, serial_run):
    path, out, proc = sweep
    assert proc.returncode == 3, proc.stderr  # finished, with failed scenes
    found = statuses(out)
    assert [s["status"] for s in found.values()] == EXPECTED
    assert {s["group"] for s in found.values()} == {0, 1}  # both groups took scenes
    for name, st in found.items():
        assert st["ranks"] == 1
        results = out / name / "results.json"
        if st["status"] == "converged":
            assert json.loads(results.read_text())["status"] == "converged"
            assert st["message"] == ""
        elif st["status"] == "stopped":
            assert json.loads(results.read_text())["diagnosis"]["cause"]
            assert st["exit_code"] == 3 and "solve stopped" in st["message"]
        else:
            assert not results.exists()
            assert st["exit_code"] == 2 and "geometry.cones" in st["message"]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging folder left
    # the sweep's solve of the reference scene is the standalone serial solve
    assert_same_state(serial_run, json.loads((out / next(iter(found)) / "results.json").read_text()))


def test_summary_in_three_formats(sweep):
    _, out, _ = sweep
    data = json.loads((out / "summary.json").read_text())
    assert [r["status"] for r in data["rows"]] == EXPECTED
    assert data["counts"] == {"converged": 3, "invalid": 1, "stopped": 1}
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [r["status"] for r in rows] == EXPECTED and rows[1]["geometry.cones"] == "1"
    md = (out / "summary.md").read_text().splitlines()
    assert sum(line.startswith("| ") for line in md) == 2 + len(EXPECTED)  # header, rule, one row per scene
    for row, st in zip(data["rows"], statuses(out).values()):
        assert row["name"] == st["name"] and row["solve_count"] == st["solve_count"]


def test_resume_solves_only_what_is_missing(sweep):
    path, out, _ = sweep
    names = list(statuses(out))
    lost = names[1]  # as if the job had been killed while solving it: no folder, a stale staging one
    shutil.rmtree(out / lost)
    before = snapshot(out)
    (out / f".{lost}.partial").mkdir()
    (out / f".{lost}.partial" / "results.json").write_text("{}")
    proc = cli(["sweep", str(path), "--out", str(out), "--schedule", "dynamic"], ranks=2, timeout=600)
    assert proc.returncode == 3, proc.stderr
    last = json.loads((out / "last_run.json").read_text())
    assert last["solved"] == [lost]
    assert sorted(last["skipped"]) == sorted(n for n in names if n != lost)
    after = snapshot(out)
    assert {k: v for k, v in after.items() if not k.startswith(f"{lost}/")} == before  # mtimes and bytes
    assert {k for k in after if k.startswith(f"{lost}/")} == {f"{lost}/results.json", f"{lost}/status.json"}
    assert all(st["solve_count"] == (0 if st["status"] == "invalid" else 1) for st in statuses(out).values())
    assert not (out / f".{lost}.partial").exists()


def test_redo_failed_solves_the_failed_scenes_again(sweep):
    path, out, _ = sweep
    before = statuses(out)
    proc = cli(["sweep", str(path), "--out", str(out), "--redo", "failed"], timeout=600)
    assert proc.returncode == 3, proc.stderr
    after = statuses(out)
    redone = json.loads((out / "last_run.json").read_text())["solved"]
    assert sorted(redone) == sorted(n for n, s in before.items() if s["status"] != "converged")
    for name, st in after.items():
        assert st["status"] == before[name]["status"]
        counted = st["status"] == "stopped"  # an invalid scene is recorded, never solved
        assert st["solve_count"] == before[name]["solve_count"] + counted


def test_summary_is_rebuilt_from_the_folders(sweep):
    path, out, _ = sweep
    old = json.loads((out / "summary.json").read_text())
    for suffix in ("json", "csv", "md"):
        (out / f"summary.{suffix}").unlink()
    proc = cli(["sweep", str(path), "--out", str(out), "--summary-only"], timeout=300)
    assert proc.returncode == 3, proc.stderr
    new = json.loads((out / "summary.json").read_text())
    assert new["rows"] == old["rows"] and new["counts"] == old["counts"]
    assert (out / "summary.csv").exists() and (out / "summary.md").exists()
