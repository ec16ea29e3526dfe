"""Shared test helpers.

Keep the number of distinct compiled forms small (FFCx compiles each new one with gcc): integration
tests use FAST (degree 1, refinement 0) unless they test something else on purpose.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PYTHON = sys.executable

#: Overrides of a quick scene: degree-1 elements, coarsest mesh, 1 N.
FAST = ["mesh.degree=1", "mesh.refinement=0", "loading.force_n=1.0"]


def mpi_env() -> dict[str, str]:
    """Environment that lets Open MPI run as root and oversubscribe the 2 cores here."""
    env = dict(os.environ)
    env.update(
        OMPI_ALLOW_RUN_AS_ROOT="1",
        OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
        OMPI_MCA_rmaps_base_oversubscribe="1",
        PYVISTA_OFF_SCREEN="true",
    )
    return env


def mpirun(n: int) -> list[str]:
    """Command prefix that launches n ranks of this interpreter's environment."""
    exe = shutil.which("mpirun") or shutil.which("mpiexec")
    if exe is None:
        pytest.fail("mpirun not found: scripts/install.sh installs openmpi-bin")
    return [exe, "-n", str(n), "--allow-run-as-root", "--oversubscribe"]


def sets(overrides: list[str]) -> list[str]:
    out: list[str] = []
    for o in overrides:
        out += ["--set", o]
    return out


def cli(args: list[str], *, ranks: int = 1, timeout: float | None = None) -> subprocess.CompletedProcess:
    """Run `suture-fem ARGS` in a fresh process (under mpirun when ranks > 1)."""
    cmd = [PYTHON, "-P", "-m", "suture_fem.cli", *args]  # -P: the current folder is not on the module path
    if ranks > 1:
        cmd = mpirun(ranks) + cmd
    return subprocess.run(cmd, capture_output=True, text=True, env=mpi_env(), cwd=ROOT, timeout=timeout)


def run_paper(tmp_path_factory, name: str, overrides: list[str], ranks: int = 1, timeout: float = 900) -> dict:
    """`suture-fem run paper` with the overrides in a fresh process, no pictures; returns results.json."""
    out = tmp_path_factory.mktemp(name)
    proc = cli(["run", "paper", *sets(overrides), "--no-pictures", "--out", str(out)], ranks=ranks, timeout=timeout)
    assert proc.returncode == 0, proc.stderr
    return json.loads((out / "results.json").read_text())


def run_inprocess(scene: str, overrides: list[str], out: Path) -> dict:
    """`suture-fem run` in this process (forms stay cached between tests); returns results.json."""
    from suture_fem.cli import main

    code = main(["run", scene, *sets(overrides), "--out", str(out)])
    assert code == 0, f"suture-fem run exited {code}"
    return json.loads((out / "results.json").read_text())
