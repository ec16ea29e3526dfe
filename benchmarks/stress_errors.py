"""The ladders behind reproduce's stress error bars: read ledgers, print studies/reproduce/stress_errors.py's table.

    .venv/bin/python benchmarks/stress_errors.py LEDGER_DIR [LEDGER_DIR ...] [--out benchmarks/out/stress_errors.json]

Each LEDGER_DIR is the output folder of one ``suture-fem convergence`` ladder at 1 N (for example
``suture-fem convergence paper_reproduction --set geometry.cones=4 --set loading.force_n=1 --forces 1
--degrees 1 --refinements 0,1,2 --out DIR``). Prints, per case (cones, tissue_scale, fillet, critical
distance), every rung's tissue measures and their error bars as ``reproduce`` computes them, then the
``LADDERS`` literal to paste into ``suture_fem/studies/reproduce/stress_errors.py``; writes the same as JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.studies.reproduce import stress_errors  # noqa: E402
from suture_fem.studies.reproduce.stress_errors import MEASURED  # noqa: E402


def read_ladder(folder: Path) -> dict:
    """{(cones, scale, fillet, distance): {(degree, refinement): {measure: value at 1 N}}} of one ledger."""
    out: dict = {}
    for rung_file in sorted((folder / "rungs").glob("*/rung.json")):
        rung = json.loads(rung_file.read_text())
        results = rung_file.with_name("results.json")
        if rung.get("status") != "converged" or not results.exists():
            continue
        scene = rung["scene"]
        key = (scene["geometry"]["cones"], scene["materials"]["tissue_scale"], scene["geometry"]["cone_fillet_mm"],
               scene["output"]["critical_distance_mm"])
        rec = next(r for r in json.loads(results.read_text())["at_forces"] if r["force_n"] == 1.0)
        tissue = rec["regions"]["tissue"]
        out.setdefault(key, {})[(rung["degree"], rung["refinement"])] = {m: tissue.get(m) for m in MEASURED}
    return out


def _wrapped(head: str, items: list[str], per_line: int = 3) -> str:
    """``head`` + the items, ``per_line`` a line (within ruff's 120 characters), closed by "},"."""
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return head + (",\n" + " " * 12).join(lines) + "},"


def main() -> None:
    """Print the rungs with their bars and the table literal; write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ledgers", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks/out/stress_errors.json")
    args = parser.parse_args()
    ladders: dict = {}
    for folder in args.ledgers:
        for key, rungs in read_ladder(folder).items():
            ladders.setdefault(key, {}).update(rungs)
    stress_errors.LADDERS.clear()
    stress_errors.LADDERS.update(ladders)
    print("| cones | tissue_scale | fillet (mm) | cd (mm) | rung | " + " | ".join(MEASURED) + " |")
    print("| ---: | ---: | ---: | ---: | --- |" + " ---: |" * len(MEASURED))
    rows = []
    for key in sorted(ladders):
        for rung in sorted(ladders[key]):
            values = ladders[key][rung]
            bars = {m: stress_errors._bar({k: v.get(m) for k, v in ladders[key].items()}, rung) for m in MEASURED}
            rows.append({"case": list(key), "rung": list(rung), "values": values, "error_rel": bars})
            cells = [("-" if values[m] is None else f"{values[m]:.5g}") + ("" if bars[m] is None else
                                                                          f" +- {100 * bars[m]:.2g} %")
                     for m in MEASURED]
            print(f"| {key[0]} | {key[1]:g} | {key[2]:g} | {key[3]:g} | P{rung[0]} r{rung[1]} | " + " | ".join(cells)
                  + " |")
    print("\nLADDERS = {")
    for key in sorted(ladders):
        print(f"    {key!r}: {{")
        for rung in sorted(ladders[key]):
            vals = {m: (None if v is None else float(f"{v:.6g}")) for m, v in ladders[key][rung].items()}
            print(_wrapped(f"        {rung!r}: {{", [f"{m!r}: {v!r}" for m, v in vals.items()]))
        print("    },")
    print("}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"rows": rows}, indent=1))
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
