"""The package's shape, checked: imports point one way, modules and functions stay small, one schema.

The layers, bottom up (docs/architecture.md; the table is scripts/architecture.py's, which draws
docs/architecture.png from the same imports): support < scene < geometry < physics < solve < outputs
< model, plots < pipeline < studies < cli. A module may import its own folder and any lower layer, never a
higher one. ``geometry.regions`` is the one table of region names and tags: it imports nothing from
the package, so every layer may read it (the scene names its material regions from it).
"""

from __future__ import annotations

import ast
import tomllib
from dataclasses import fields
from pathlib import Path

import pytest

from scripts.architecture import (
    LAYERS,
    LEAF_TABLES,
    PACKAGE,
    ROOT,
    STUDY_RANKS,
    imports_of,
    module_name,
    study_edges,
    study_of,
)

MAX_MODULE_LINES = 400
MAX_FUNCTION_LINES = 60


def _layer(module: str) -> tuple[str, int] | None:
    parts = module.split(".")
    if len(parts) < 2 or parts[1] not in LAYERS:
        return None  # the package root (__version__)
    return parts[1], LAYERS[parts[1]]


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_imports_point_one_way():
    back_edges = []
    for path in _sources():
        me = module_name(path)
        mine = _layer(me)
        for line, target in imports_of(path):
            if me in LEAF_TABLES:
                back_edges.append(f"{me}:{line} imports {target} (a leaf table imports nothing)")
                continue
            if any(target == t or target.startswith(t + ".") for t in LEAF_TABLES):
                continue
            theirs = _layer(target)
            if mine is None or theirs is None or theirs[0] == mine[0]:
                continue
            if theirs[1] >= mine[1]:
                back_edges.append(f"{me}:{line} ({mine[0]}) imports {target} ({theirs[0]})")
    assert not back_edges, "imports against the pipeline's direction:\n" + "\n".join(back_edges)


def test_studies_import_only_the_studies_they_build_on():
    """No cycle between studies: an import (at any depth, lazy ones included) goes to a lower-ranked study."""
    against = [f"{me}:{line} imports {target}" for me, line, target, mine in study_edges()
               if STUDY_RANKS.get(study_of(target), 1) >= STUDY_RANKS.get(mine, 1)]
    assert not against, "imports between studies against scripts/architecture.py's STUDY_RANKS:\n" + "\n".join(against)
    assert {study_of(t) for _, _, t, _ in study_edges()} <= set(STUDY_RANKS)  # each one built on is ranked


@pytest.mark.parametrize("folder", ["demos", "benchmarks", "suture_fem"])
def test_only_the_command_line_imports_the_command_line(folder):
    offenders = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        if path.is_relative_to(PACKAGE / "cli"):
            continue
        offenders += [f"{path.relative_to(ROOT)}:{line}" for line, t in imports_of(path)
                      if t == "suture_fem.cli" or t.startswith("suture_fem.cli.")]
    assert not offenders, "outside cli/, only subprocesses may run the command line: " + ", ".join(offenders)


def test_modules_and_functions_stay_small():
    too_long = []
    for path in _sources():
        lines = len(path.read_text().splitlines())
        if lines > MAX_MODULE_LINES:
            too_long.append(f"{path.relative_to(ROOT)}: {lines} lines (module limit {MAX_MODULE_LINES})")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    too_long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {n} lines "
                                    f"(function limit {MAX_FUNCTION_LINES})")
    assert not too_long, "split by responsibility:\n" + "\n".join(too_long)


def test_every_declared_key_has_a_default_and_every_default_is_declared():
    from suture_fem.scene.schema import SECTIONS

    defaults = tomllib.loads((PACKAGE / "scene" / "defaults.toml").read_text())
    for name, section in SECTIONS.items():
        assert set(defaults[name]) == {f.name for f in fields(section)}, name
    assert set(defaults) == {*SECTIONS, "materials"}


def test_the_command_line_does_not_import_scipy_until_a_study_needs_it():
    """Building the parser and the run pipeline imports no scipy (it cost every command 0.3 s of CPU, issue 14).

    The calibration imports scipy inside the functions that fit and give intervals.
    """
    import subprocess
    import sys

    code = ("import sys; import suture_fem.pipeline, suture_fem.cli.run_report; "
            "from suture_fem.cli.main import build_parser; build_parser(); "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]", out.stdout
