"""Benchmark: the holding force against the cone count, at degree 1 and 2, and what the fat's strength decides.

For 1-4 cones on the paper scene, ``suture-fem holding`` (in this process, one model per case): the
first failure's force, its bracket and its band from the strengths' published spread, the mode, layer
and cone, and the CPU seconds, at mesh.degree 1 and 2 (the difference is the discretisation's share
of the answer; the paper scene is degree 2). Prints a table and writes JSON.

    .venv/bin/python benchmarks/holding_cones.py [--out benchmarks/out/holding_cones] [--tol 0.01]
        [--degrees 1,2] [--cones 1,2,3,4]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from suture_fem import Scene
from suture_fem.studies.holding.study import holding


def case(cones: int, degree: int, tol: float, out: Path) -> dict:
    """One holding study; its record's answer and cost."""
    scene = Scene.builtin("paper").with_values({"geometry.cones": cones, "mesh.degree": degree})
    t0 = time.process_time()
    rec = holding(scene, None, tol_n=tol, out=out / f"cones{cones}_p{degree}", name=f"paper, {cones} cones, P{degree}")
    keep = ("force_n", "bracket_n", "band_n", "band_modes", "mode", "layer", "cone", "at_mm", "parts_n", "passes")
    return {"cones": cones, "degree": degree, "cpu_s": round(time.process_time() - t0, 1),
            **{k: rec[k] for k in keep}}


def table(rows: list[dict]) -> str:
    """The rows as a markdown table."""
    def n(v: float | None) -> str:
        return "-" if v is None else f"{v:.3g}"

    lines = ["| cones | P | holding force (N) | bracket (N) | band (N) | first failure | CPU (s) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        where = f"{r['mode']}: {r['layer'] or 'thread'}" + (f" at {r['cone']}" if r["cone"] else "")
        lo, hi = r["bracket_n"] or (None, None)
        lines.append(f"| {r['cones']} | {r['degree']} | {n(r['force_n'])} | {n(lo)} - {n(hi)} | "
                     f"{n(r['band_n'][0])} - {n(r['band_n'][1])} | {where} | {r['cpu_s']} |")
    return "\n".join(lines)


def main() -> None:
    """Run every case, print the table, write the JSON."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="benchmarks/out/holding_cones")
    p.add_argument("--tol", type=float, default=0.01)
    p.add_argument("--degrees", default="1,2")
    p.add_argument("--cones", default="1,2,3,4")
    args = p.parse_args()
    out = Path(args.out)
    degrees, cones = map(int, args.degrees.split(",")), [int(c) for c in args.cones.split(",")]
    rows = [case(c, d, args.tol, out) for d in degrees for c in cones]
    print(table(rows))
    out.mkdir(parents=True, exist_ok=True)
    (out / "holding_cones.json").write_text(json.dumps(rows, indent=1))
    print(f"wrote {out / 'holding_cones.json'}")


if __name__ == "__main__":
    main()
