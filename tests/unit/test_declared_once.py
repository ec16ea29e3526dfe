"""Names declared in one place: the optional outputs (scene/schema.py) and the regions (geometry/regions.py)."""

from __future__ import annotations

import ast
from dataclasses import fields

import pytest

from suture_fem.geometry.regions import REGIONS, REPORTED_REGIONS, WHOLE_TISSUE
from tests.conftest import ROOT

#: String literals equal to a region's name that are not a region: (file, name) -> what they are.
NOT_REGIONS = {
    ("suture_fem/geometry/gmsh_model.py", "suture"): "gmsh's model name",
    ("suture_fem/geometry/mesh.py", "suture"): "gmsh's model name",
    ("suture_fem/physics/boundary.py", "suture"): "the effect effects.suture's notes",
    ("suture_fem/physics/effects/record.py", "suture"): "the effect effects.suture's record",
    ("suture_fem/scene/model.py", "hypodermis"): "MaterialsSection's defaults (its fields are checked below)",
    ("suture_fem/scene/model.py", "dermis"): "as above",
    ("suture_fem/scene/model.py", "epidermis"): "as above",
    ("suture_fem/scene/model.py", "suture"): "as above",
}


def _literals(path):
    """The package's string constants that are not docstrings: (line, value)."""
    tree = ast.parse(path.read_text())
    docs = {id(node.body[0].value) for node in ast.walk(tree)
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
            and node.body and isinstance(node.body[0], ast.Expr) and isinstance(node.body[0].value, ast.Constant)}
    return [(n.lineno, n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_region_names_are_written_only_in_the_region_table():
    found = []
    for path in sorted((ROOT / "suture_fem").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel == "suture_fem/geometry/regions.py":
            continue
        found += [f"{rel}:{line}: {value!r}" for line, value in _literals(path)
                  if value in REPORTED_REGIONS and (rel, value) not in NOT_REGIONS]
    assert found == [], "use geometry/regions.py's names (REGIONS, TISSUE_REGIONS, SUTURE_REGION, WHOLE_TISSUE)"
    from suture_fem.scene.model import MaterialsSection

    assert [f.name for f in fields(MaterialsSection) if f.name != "tissue_scale"] == list(REGIONS)
    assert WHOLE_TISSUE not in REGIONS


def test_each_optional_output_is_declared_once_and_computed_by_one_quantity():
    from suture_fem.outputs.base import Quantity
    from suture_fem.outputs.evaluate import QUANTITIES
    from suture_fem.physics.effects import QUANTITIES as RECORDED
    from suture_fem.scene.schema import OUTPUT_QUANTITIES, POINT_QUANTITIES, RULES

    options = [cls.option for cls in QUANTITIES if cls.option is not None]
    assert sorted(options) == sorted(OUTPUT_QUANTITIES) and len(set(options)) == len(options)
    assert RULES["output.quantities"].choices == OUTPUT_QUANTITIES and RECORDED is OUTPUT_QUANTITIES
    assert set(POINT_QUANTITIES) <= set(OUTPUT_QUANTITIES)
    with pytest.raises(TypeError, match="not declared in scene.schema.OUTPUT_QUANTITIES"):
        type("Misspelt", (Quantity,), {"option": "seqvv"})
