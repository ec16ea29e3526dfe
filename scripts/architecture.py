"""The package's import graph by folder, and the picture of it in docs/architecture.png.

    .venv/bin/python scripts/architecture.py            # redraw docs/architecture.png, print the edges

The layer table below is the one the architecture test (tests/unit/test_architecture.py) enforces:
a module may import its own folder and the layers below it, never one above. The picture is drawn
from the package's real imports, so it cannot drift from the code.
"""

from __future__ import annotations

import ast
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "suture_fem"
#: Layers, bottom up; folders (or top-level modules) on one layer do not import each other.
LAYERS: dict[str, int] = {"support": 0, "scene": 1, "geometry": 2, "physics": 3, "solve": 4, "outputs": 5,
                          "model": 6, "plots": 6, "pipeline": 7, "studies": 8, "cli": 9}
#: Leaf tables every layer may read: they import nothing from the package.
LEAF_TABLES = {"suture_fem.geometry.regions"}
#: The studies (packages or modules of ``studies/``) that other studies build on, bottom up: a study
#: imports only studies of a lower rank (every study not named here has rank 1 and imports none).
#: ``paper`` is the paper's table of values; ``reproduce`` fits with ``calibrate``, never the reverse.
STUDY_RANKS: dict[str, int] = {"paper": 0, "calibrate": 1, "reproduce": 2}


def module_name(path: Path) -> str:
    """Dotted module name of a file of the package."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every ``suture_fem`` import of a file, at any depth (lazy imports included)."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.startswith("suture_fem")]
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("suture_fem"):
            found += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
    return found


def study_of(module: str) -> str | None:
    """The study (package or module under ``suture_fem.studies``) a module name belongs to, else None."""
    parts = module.split(".")
    return parts[2] if len(parts) > 2 and parts[:2] == ["suture_fem", "studies"] else None


def study_edges() -> list[tuple[str, int, str, str]]:
    """(importing module, line, imported module, importing study) of every import from one study into another."""
    edges = []
    for path in sorted((PACKAGE / "studies").rglob("*.py")):
        me = module_name(path)
        mine = study_of(me)
        for line, target in imports_of(path):
            theirs = study_of(target)
            if mine is not None and theirs is not None and theirs != mine:
                edges.append((me, line, target, mine))
    return edges


def folder_of(module: str) -> str | None:
    """The layer folder of a module name (None for the package root, e.g. ``suture_fem.__version__``)."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS else None


def folder_edges() -> Counter:
    """(importing folder, imported folder) -> number of import statements, leaf tables apart."""
    edges: Counter = Counter()
    for path in sorted(PACKAGE.rglob("*.py")):
        me = folder_of(module_name(path))
        for _, target in imports_of(path):
            theirs = folder_of(target)
            if any(target == t or target.startswith(t + ".") for t in LEAF_TABLES):
                theirs = "regions"
            if me and theirs and me != theirs:
                edges[(me, theirs)] += 1
    return edges


def draw(png: Path) -> None:
    """Layers as rows (bottom up), one box per folder, an arrow per folder-to-folder import."""
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch

    rows: dict[int, list[str]] = {}
    for name, level in LAYERS.items():
        rows.setdefault(level, []).append(name)
    pos = {}
    for level, names in rows.items():
        for i, name in enumerate(names):
            pos[name] = (2.0 + 2.6 * (i - (len(names) - 1) / 2), 1.0 + level)
    pos["regions"] = (5.2, 2.6)
    notes = {"support": "compat, parallel, io, errors, logging", "scene": "schema, load, model (typed Scene)",
             "geometry": "section, gmsh_model, mesh", "physics": "kinematics, materials, forms, effects/, problem",
             "solve": "newton, reduction, guard, stepping, diagnosis", "outputs": "one class per quantity, results",
             "model": "Model: build once, solve, set", "pipeline": "load_scene, run_scene",
             "plots": "pyvista / matplotlib",
             "studies": "verification, convergence, sweep, reproduce, maxload, hardcases",
             "cli": "argument parsing and commands", "regions": "the one table of region names and tags"}
    fig = Figure(figsize=(9.5, 8.5))
    ax = fig.subplots()
    for name, (x, y) in pos.items():
        ax.add_patch(FancyBboxPatch((x - 1.15, y - 0.28), 2.3, 0.56, boxstyle="round,pad=0.02",
                                    fc="#eef3fb" if name != "regions" else "#fdf3e1", ec="#36506e"))
        ax.text(x, y + 0.08, name + "/" if name not in ("model", "pipeline", "plots", "regions") else name + ".py",
                ha="center", va="center", fontsize=10, weight="bold")
        ax.text(x, y - 0.14, notes[name], ha="center", va="center", fontsize=6.5, color="#333")
    for (a, b), n in sorted(folder_edges().items()):
        (xa, ya), (xb, yb) = pos[a], pos[b]
        ax.add_patch(FancyArrowPatch((xa, ya - 0.28), (xb, yb + 0.28), arrowstyle="-|>", mutation_scale=9,
                                     lw=0.5 + 0.15 * min(n, 10), color="#7a8ea8", alpha=0.8,
                                     connectionstyle="arc3,rad=0.08"))
    ax.set_xlim(-2.2, 7.4)
    ax.set_ylim(0.3, 10.6)
    ax.axis("off")
    ax.set_title("suture_fem: imports point down the pipeline (arrow: 'imports'; drawn from the code)", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main() -> int:
    """Print the folder edges and redraw the picture."""
    for (a, b), n in sorted(folder_edges().items(), key=lambda e: (-LAYERS.get(e[0][0], 0), e[0])):
        print(f"{a:>9} -> {b:<9} {n:3d} imports")
    png = ROOT / "docs" / "architecture.png"
    draw(png)
    print(f"wrote {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
