"""`mpirun -n 2 suture-fem run`: the same numbers as the serial run, files and logs written once,
and a failure on one rank ends every rank with one message instead of a hang."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from tests.conftest import PYTHON, ROOT, cli, mpi_env, mpirun, sets
from tests.mpi.conftest import REL, SCENE

pytestmark = pytest.mark.mpi

QUANTITIES = ("usum_mm", "seqv_pa", "eptoeqv", "seqv_outside_rim_pa", "thread_end_displacement_mm",
              "reaction_force_n", "strain_energy_j", "seqv_cd_pa", "eptoeqv_cd", "seqv_fillet_pa", "eptoeqv_fillet")
#: The critical-distance averages of each tissue layer and of the whole tissue.
CD_REGIONS = ("hypodermis", "dermis", "epidermis", "tissue")
REGIONS = ("hypodermis", "dermis", "epidermis", "suture", "tissue")


@pytest.fixture(scope="module")
def parallel_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("parallel")
    proc = cli(["run", "paper", *sets(SCENE), "--fields", "--out", str(out)], ranks=2, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc, out, json.loads((out / "results.json").read_text())


def assert_same_state(a: dict, b: dict) -> None:
    """Every output of two results.json at every reported force, to relative REL."""
    assert [r["force_n"] for r in a["at_forces"]] == [r["force_n"] for r in b["at_forces"]] == [0.5, 1.0]
    for ra, rb in zip(a["at_forces"], b["at_forces"]):
        for q in QUANTITIES:
            assert rb[q] == pytest.approx(ra[q], rel=REL), (ra["force_n"], q)
        for region in REGIONS:
            for q in ("usum_mm", "seqv_pa", "eptoeqv"):
                assert rb["regions"][region][q] == pytest.approx(ra["regions"][region][q], rel=REL), (region, q)
        for region in CD_REGIONS:
            for q in ("seqv_cd_pa", "eptoeqv_cd"):
                ea, eb = ra["regions"][region], rb["regions"][region]
                assert eb[q] == pytest.approx(ea[q], rel=REL), (region, q)
                assert eb[q + "_at_mm"] == pytest.approx(ea[q + "_at_mm"], abs=1e-9), (region, q)  # the same disc
        for q in ("seqv_cd_cone_pa", "eptoeqv_cd_cone"):  # the tissue's averages near a cone
            ea, eb = ra["regions"]["tissue"], rb["regions"]["tissue"]
            assert eb[q] == pytest.approx(ea[q], rel=REL), q
            assert eb[q + "_at_mm"] == pytest.approx(ea[q + "_at_mm"], abs=1e-9), q
    # The curve: every point is an equilibrium, so at every force both runs reached the displacements agree.
    # The step sequence itself may differ (a partition's round-off moves a Newton count across the step
    # controller's threshold: on Debian 13, 4 ranks took 8 steps where the serial run took 9); the issue
    # asks to assert the physics, not a trajectory.
    fa, fb = np.array(a["force_displacement"]), np.array(b["force_displacement"])
    assert fa[0].tolist() == fb[0].tolist() == [0.0, 0.0] and fb[-1, 0] == pytest.approx(fa[-1, 0], rel=1e-12)
    common = [(i, j) for i, f in enumerate(fa[:, 0]) for j, g in enumerate(fb[:, 0]) if abs(f - g) <= 1e-12 * fa[-1, 0]]
    reports = {r["force_n"] for r in a["at_forces"]}
    assert reports <= {fa[i, 0] for i, _ in common}  # the report forces at least
    for i, j in common:
        assert fb[j, 1] == pytest.approx(fa[i, 1], rel=REL), fa[i, 0]


def test_two_ranks_give_the_serial_results(serial_run, parallel_run):
    _, _, par = parallel_run
    assert (serial_run["mpi_ranks"], par["mpi_ranks"]) == (1, 2)
    assert par["status"] == serial_run["status"] == "converged"
    assert (par["dofs"], par["cells"]) == (serial_run["dofs"], serial_run["cells"])
    assert_same_state(serial_run, par)


def test_two_ranks_log_once_and_write_each_file_once(parallel_run):
    proc, out, _ = parallel_run
    steps = [line for line in proc.stderr.splitlines() if "step   1 " in line]
    assert len(steps) == 1, proc.stderr
    assert proc.stdout.count("results in") == 1
    # the fields, the results and the three pictures a run draws by default, each once, from
    # rank 0
    assert sorted(p.name for p in out.iterdir()) == ["fields.h5", "fields.xdmf", "force_displacement.png",
                                                     "interface.png", "results.json", "usum.png"]


def test_a_failure_on_rank_0_ends_every_rank(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    proc = cli(["run", "paper", *sets(SCENE), "--out", str(blocker / "out")], ranks=2, timeout=300)
    assert proc.returncode == 1
    errors = [line for line in proc.stderr.splitlines() if line.startswith("suture-fem: error:")]
    assert len(errors) == 1 and "creating the output folder" in errors[0], proc.stderr


def test_a_bad_scene_stops_every_rank_with_one_line():
    proc = cli(["run", "paper", "--set", "geometry.cones=-1"], ranks=2, timeout=300)
    assert proc.returncode == 2
    errors = [line for line in proc.stderr.splitlines() if line.startswith("suture-fem: error:")]
    assert len(errors) == 1 and "geometry.cones" in errors[0], proc.stderr


ONE_CONE = SCENE + ["geometry.cones=1"]
#: Under mpirun -n 4: which ranks own cone cells, then the solve on the world communicator.
PARTITIONED_RUN = """
import json, sys
import numpy as np
from mpi4py import MPI
from suture_fem.geometry import mesh
from suture_fem.geometry import regions
from suture_fem.pipeline import run_scene
from suture_fem.pipeline import load_scene

comm = MPI.COMM_WORLD
scene = load_scene("paper", sys.argv[2:])
tagged = mesh.create_mesh(comm, scene.geometry, scene.mesh)
owned = tagged.mesh.topology.index_map(2).size_local
ct = tagged.cell_tags
cones = comm.gather(int(np.sum(ct.values[ct.indices < owned] == regions.Cell.CONE)), root=0)
run_scene(scene, sys.argv[1], comm)
if comm.rank == 0:
    json.dump(cones, open(sys.argv[1] + "/cone_cells_per_rank.json", "w"))
"""


@pytest.mark.long  # 4 ranks on 2 cores: 13 s; benchmarks/long_tests.py
def test_four_ranks_with_one_owning_no_cone_cell(tmp_path):
    """Maxima over a region are reduced over every rank, also over ranks that own none of its cells."""
    serial = tmp_path / "serial"
    proc = cli(["run", "paper", *sets(ONE_CONE), "--out", str(serial)], timeout=600)
    assert proc.returncode == 0, proc.stderr
    script = tmp_path / "partitioned_run.py"
    script.write_text(PARTITIONED_RUN)
    out = tmp_path / "four"
    proc = subprocess.run(mpirun(4) + [PYTHON, str(script), str(out), *ONE_CONE], capture_output=True, text=True,
                          env=mpi_env(), cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr
    cones = json.loads((out / "cone_cells_per_rank.json").read_text())
    assert min(cones) == 0 < max(cones), f"premise: some rank should own no cone cell, got {cones}"
    assert_same_state(json.loads((serial / "results.json").read_text()), json.loads((out / "results.json").read_text()))
