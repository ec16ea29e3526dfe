"""Every dolfinx / numpy version difference lives in support/compat.py: the rest of the package uses none.

Each spelling below works on only one side of a version boundary the project supports (Debian 12:
dolfinx 0.5.2, numpy 1.24; Debian 13: dolfinx 0.9.0, numpy 2.2). Found outside compat.py, it is a
break waiting for the other release.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SPELLINGS = {
    r"\.dofmap\.list\.array": "a dofmap's cell dofs are 2-D from dolfinx 0.7: compat.cell_dofs",
    r"geometry\.dofmap\.array": "the geometry dofmap is 2-D from dolfinx 0.7: compat.geometry_dofs",
    r"\bVectorFunctionSpace\b": "removed in dolfinx 0.8: compat.vector_space",
    r"fem\.FunctionSpace\(": "dolfinx >= 0.8 spells it functionspace: compat.scalar_space / vector_space",
    r"\bcreate_vtk_mesh\b": "renamed vtk_mesh in dolfinx 0.7: compat.vtk_mesh",
    r"apply_lifting\([^)]*scale\s*=": "scale= is alpha= in dolfinx 0.9",
    r"\bnp\.cross\(": "2-D vectors are deprecated in numpy 2: write the 2-D cross product out",
    r"\.vector\b(?!_)": "Function.vector is x.petsc_vec from dolfinx 0.8: compat.function_vector",
    r"\bmodel_to_mesh\(": "gmshio's return value differs across versions: compat.gmsh_model_to_mesh",
    r"setFunctionDomainError": "absent from petsc4py 3.18 and 3.22: compat.set_function_domain_error",
    r"la\.ScatterMode|InsertMode\.add\b": "dolfinx.la scatter modes changed in 0.7: compat.scatter_reverse_add",
}


def _sources():
    for folder in ("suture_fem", "tests", "demos", "benchmarks"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path.name in ("compat.py", Path(__file__).name):
                continue
            yield path


@pytest.mark.parametrize("pattern", list(SPELLINGS))
def test_version_specific_spellings_only_in_compat(pattern):
    found = []
    for path in _sources():
        for number, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            if re.search(pattern, code):
                found.append(f"{path.relative_to(ROOT)}:{number}: {line.strip()}")
    assert not found, f"{SPELLINGS[pattern]}:\n" + "\n".join(found)
