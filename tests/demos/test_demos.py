"""Every demo runs top to bottom as a notebook, in the project's Jupyter kernel.

The demos are found by a glob (``demos/*.py``; files starting with ``_`` are helpers, not demos),
so a new demo cannot be left out. Each is converted by jupytext to a notebook in memory and
executed by nbclient with ``CI=1`` (the demos then use a coarser discretisation) in a temporary
working folder; a failing cell raises and fails the test. The demos assert the claims of their own
conclusions in their last code cells.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import jupytext
import pytest
from jupyter_client.kernelspec import KernelSpecManager, NoSuchKernel
from nbclient import NotebookClient

from tests.conftest import ROOT, mpi_env

DEMOS_DIR = ROOT / "demos"
DEMOS = sorted(p for p in DEMOS_DIR.glob("*.py") if not p.name.startswith("_"))
#: The kernel scripts/install.sh registers for this environment's Python.
KERNEL = "suture-fem"


def test_demos_are_found():
    assert {"quickstart.py", "cone_design.py", "python_api.py"} <= {p.name for p in DEMOS}


def test_no_notebook_is_committed():
    """Demos live as .py files only; executed notebooks (with outputs) stay out of git."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    tracked = subprocess.run(["git", "ls-files", "*.ipynb"], cwd=ROOT, capture_output=True, text=True, check=True)
    assert tracked.stdout.split() == []


def test_kernel_runs_this_environment():
    """The demos' kernel starts this virtual environment's Python (install.sh registers it)."""
    try:
        spec = KernelSpecManager().get_kernel_spec(KERNEL)
    except NoSuchKernel:
        pytest.fail(f"no Jupyter kernel {KERNEL!r}: scripts/install.sh registers it")
    assert Path(spec.argv[0]).absolute() == Path(sys.executable).absolute()


def test_demos_use_only_the_public_api():
    """``import suture_fem as sf`` and the names of its ``__all__`` (docs/api.md): no deep module path, no helper."""
    import ast

    import suture_fem

    public, found = set(suture_fem.__all__), []
    for path in DEMOS:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found += [f"{path.name}:{node.lineno}: import {a.name}" for a in node.names
                          if a.name.startswith("suture_fem.") or (DEMOS_DIR / f"{a.name.split('.')[0]}.py").exists()]
            elif isinstance(node, ast.ImportFrom) and node.module:
                top = node.module.split(".")[0]
                deep = node.module.startswith("suture_fem.") or (top == "suture_fem" and not all(
                    a.name in public for a in node.names))
                if deep or (DEMOS_DIR / f"{top}.py").exists():
                    found.append(f"{path.name}:{node.lineno}: from {node.module} import ...")
            elif (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "sf"
                  and node.attr not in public):
                found.append(f"{path.name}:{node.lineno}: sf.{node.attr}")
    assert found == []


#: The demos that take longest as notebooks (20-30 s each): in the long tests (benchmarks/long_tests.py).
LONG_DEMOS = ("cone_design", "paper_reproduction", "hard_cases", "effects", "accuracy_cost")


@pytest.mark.slow
@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.long) if p.stem in LONG_DEMOS else p
                                  for p in DEMOS], ids=[p.stem for p in DEMOS])
def test_demo_runs_as_notebook(path: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    nb = jupytext.read(path)
    assert nb.metadata.get("kernelspec", {}).get("name") == KERNEL, f"{path.name}: kernelspec must be {KERNEL!r}"
    headings = [c.source for c in nb.cells if c.cell_type == "markdown"]
    assert headings and headings[-1].startswith("## Conclusion"), f"{path.name} must end with a Conclusion"
    for key, value in mpi_env().items():  # the kernel inherits this process's environment
        monkeypatch.setenv(key, value)
    monkeypatch.setenv("CI", "1")
    client = NotebookClient(nb, timeout=1800, kernel_name=KERNEL, resources={"metadata": {"path": str(tmp_path)}})
    client.execute()
