"""Check: results.json of one ``suture-fem run`` is the same on another commit's code and on this tree.

    .venv/bin/python benchmarks/results_identity.py [--base main] [--set KEY=VALUE ...] [--scene paper]
        [--out benchmarks/out/results_identity]

The base commit's files are exported with ``git archive`` into /var/tmp (no worktree, nothing in the
repository changes) and run with PYTHONPATH pointing at them; this tree runs as installed. Each run is
``suture-fem run SCENE --set ... --out DIR`` in its own process. The two results.json are compared key
by key, ignoring what may differ between two runs of the same code (``wall_time_s``, ``timings_s``,
``process``): the keys must be the same, every string, integer and boolean equal, every float equal
bit for bit (the table also gives the largest relative difference). Prints a table, writes JSON and
exits 1 when they differ. The default is the paper scene at 0.5 N with a report at 0.25 N.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
#: What two runs of the same code may write differently.
NOT_COMPARED = ("wall_time_s", "timings_s", "process")
DEFAULT_SETS = ["loading.force_n=0.5", "loading.report_forces_n=[0.25]"]


def export(commit: str) -> Path:
    """The files of ``commit`` under /var/tmp (exported once, reused)."""
    sha = subprocess.run(["git", "-C", str(ROOT), "rev-parse", commit], capture_output=True, text=True,
                         check=True).stdout.strip()
    path = Path("/var/tmp") / f"suture_fem-code-{sha[:12]}"
    if not (path / "suture_fem" / "__init__.py").is_file():
        path.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", "--format=tar", sha], capture_output=True,
                                 check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(path)], input=archive, check=True)
    return path


def run(code: Path, scene: str, sets: list[str], out: Path) -> dict[str, Any]:
    """``suture-fem run`` of the package in ``code`` (its own process); results.json, exit code, wall time."""
    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1")
    where = subprocess.run([sys.executable, "-P", "-c", "import suture_fem; print(suture_fem.__file__)"], env=env,
                           cwd=code, capture_output=True, text=True, check=True).stdout.strip()
    assert Path(where).is_relative_to(code), f"{code}: imported {where}"
    args = [arg for s in sets for arg in ("--set", s)]
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-P", "-m", "suture_fem.cli", "run", scene, *args, "--out", str(out)],
                          env=env, cwd=code, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{code}: suture-fem run exited {proc.returncode}: {proc.stderr[-2000:]}")
    return {"results": json.loads((out / "results.json").read_text()), "wall_s": time.perf_counter() - t0}


def differences(a: Any, b: Any, path: str = "") -> tuple[list[str], int, float]:
    """(the paths where a and b differ, the number of floats compared, the largest relative float difference)."""
    if isinstance(a, dict) and isinstance(b, dict):
        found, floats, worst = [], 0, 0.0
        for key in sorted(set(a) | set(b)):
            if key not in a or key not in b:
                found.append(f"{path}.{key}: only in {'the base' if key in a else 'this tree'}")
                continue
            f, n, w = differences(a[key], b[key], f"{path}.{key}")
            found, floats, worst = found + f, floats + n, max(worst, w)
        return found, floats, worst
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        found, floats, worst = [], 0, 0.0
        for i, (x, y) in enumerate(zip(a, b)):
            f, n, w = differences(x, y, f"{path}[{i}]")
            found, floats, worst = found + f, floats + n, max(worst, w)
        return found, floats, worst
    if isinstance(a, float) and isinstance(b, float):
        rel = abs(a - b) / max(abs(a), abs(b), 1e-300)
        return ([] if a == b else [f"{path}: {a!r} != {b!r}"]), 1, rel
    return ([] if a == b and type(a) is type(b) else [f"{path}: {a!r} != {b!r}"]), 0, 0.0


def main() -> int:
    """Run both, compare, print the table, write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main", help="the commit to compare with (default main)")
    parser.add_argument("--scene", default="paper")
    parser.add_argument("--set", action="append", dest="sets", help=f"scene overrides (default {DEFAULT_SETS})")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "results_identity"))
    args = parser.parse_args()
    sets = args.sets if args.sets is not None else DEFAULT_SETS
    out = Path(args.out).resolve()
    runs = {"base": run(export(args.base), args.scene, sets, out / "base"),
            "this tree": run(ROOT, args.scene, sets, out / "this_tree")}
    a, b = ({k: v for k, v in r["results"].items() if k not in NOT_COMPARED} for r in runs.values())
    found, floats, worst = differences(a, b)
    record = {"base": args.base, "scene": args.scene, "sets": sets, "ignored": list(NOT_COMPARED),
              "top_level_keys": len(a), "floats_compared": floats, "max_relative_difference": worst,
              "identical": not found, "differences": found[:50],
              "wall_s": {k: round(r["wall_s"], 1) for k, r in runs.items()},
              "usum_mm": {k: r["results"].get("usum_mm") for k, r in runs.items()}}
    print(f"suture-fem run {args.scene} {' '.join('--set ' + s for s in sets)}: {args.base} against this tree")
    print(f"| {'top-level keys':<16} | {'floats':>7} | {'max rel. diff':>13} | {'identical':<9} "
          "| wall s (base, this) |")
    print(f"| {len(a):<16} | {floats:>7} | {worst:>13.3g} | {str(not found):<9} | "
          f"{record['wall_s']['base']}, {record['wall_s']['this tree']} |")
    for line in found[:20]:
        print("  differs:", line)
    (out / "identity.json").write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {out / 'identity.json'}")
    return 0 if not found else 1


if __name__ == "__main__":
    sys.exit(main())
