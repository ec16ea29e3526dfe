"""Benchmark: the accuracy-cost ledger of the paper scene (4 hollow cones, 1 N and 4 N), sharp and filleted rims.

Runs `suture-fem convergence` for each ladder below (every rung in its own process; rungs already
solved in OUT are reused, so an interrupted run resumes), prints a summary table and writes
OUT/summary.json and OUT/summary.md (the tables of every ledger, for docs/ledger.md).

    .venv/bin/python benchmarks/ledger.py [--out benchmarks/out/ledger] [--only paper] [--summary-only]
    .venv/bin/python benchmarks/ledger.py --only stress-1cone-p2 --only stress-4cones-p2   # issue 17's ladders
    .venv/bin/python benchmarks/ledger.py --only fillet-1cone-p2 --only fillet-1cone-farfield  # fillet refined only
    .venv/bin/python benchmarks/ledger.py --only curved-global-1cone --only curved-global-4cones  # quadratic cells

The finest rungs are slow on a 2-core machine (degree 1 refinement 2: about 100k cells; degree 2 is
stopped at refinement 1): the whole benchmark takes 30-60 minutes there.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.support.io import write_json, write_text  # noqa: E402

#: name -> (title, extra arguments of `suture-fem convergence paper`)
LADDERS = {
    "paper": ("paper scene, sharp rims", []),
    "paper-fillet": ("paper scene, base rims rounded (geometry.cone_fillet_mm = 0.05)",
                     ["--set", "geometry.cone_fillet_mm=0.05"]),
}
COMMON = ["--degrees", "1,2", "--refinements", "0,1,2", "--cap", "2=1", "--forces", "1,4"]
#: The ladders of issue 17's converging stress measures (the 0.04 mm fillet, degree 2; docs/ledger.md):
#: name -> (title, every argument after the scene name). Not run by default (--only NAME).
FILLET = ["--set", "geometry.cone_fillet_mm=0.04", "--degrees", "2"]
ONE_CONE = ["--set", "geometry.cones=1", "--set", "loading.force_n=1", "--forces", "1"]
#: refinement 1 and fillet level 4: 8 x 2^4 elements along each arc, doubled by the refinement = 256, the
#: finest fillet level's count at refinement 0 (level 5)
FAR_FIELD = ["--set", "mesh.refinement=1", "--refinements", "4", "--refine", "fillet"]
#: refinement 1, 4 x 2^k elements along each arc, doubled by the refinement: 8 to 512 (the key's maximum 256)
R1_FILLET = ["--set", "mesh.refinement=1", "--set", "mesh.fillet_elements=4", "--refinements", "0,1,2,3,4,5,6",
             "--refine", "fillet"]
#: the same on quadratic cells (the arcs' mid-side nodes on the arcs)
CURVED = ["--set", "mesh.geometry_degree=2", *R1_FILLET[:4], "--refinements", "0,1,2,3,4,5,6", "--refine", "fillet"]
CURVED_GLOBAL = ["--set", "mesh.geometry_degree=2", "--set", "mesh.fillet_elements=32", "--refinements", "0,1,2"]
STRESS_LADDERS = {
    "stress-1cone-p2": ("1 cone, 1 N, fillet 0.04 mm, P2", [*FILLET, *ONE_CONE, "--refinements", "0,1,2"]),
    "stress-1cone-mixed": ("1 cone, 1 N, fillet 0.04 mm, P2/P1 mixed",
                           [*FILLET, *ONE_CONE, "--refinements", "0,1,2", "--formulations", "mixed"]),
    "stress-4cones-p2": ("4 cones, fillet 0.04 mm, P2", [*FILLET, "--forces", "1,4", "--refinements", "0,1"]),
    # only the fillet refined (8..256 elements along each arc, the far field at refinement 0), and the
    # far-field check: the finest arc (256 elements) at refinement 1
    "fillet-4cones-p2": ("4 cones, fillet 0.04 mm, P2, only the fillet refined",
                         [*FILLET, "--forces", "1,4", "--refinements", "0,1,2,3,4,5", "--refine", "fillet"]),
    "fillet-1cone-p2": ("1 cone, 1 N, fillet 0.04 mm, P2, only the fillet refined",
                        [*FILLET, *ONE_CONE, "--refinements", "0,1,2,3,4,5", "--refine", "fillet"]),
    # the same at refinement 1 from 4 elements per arc at refinement 0 (8 at refinement 1) to 512
    "fillet-4cones-p2-r1": ("4 cones, fillet 0.04 mm, P2 r1, only the fillet refined",
                            [*FILLET, *R1_FILLET, "--forces", "1,4"]),
    "fillet-1cone-p2-r1": ("1 cone, 1 N, fillet 0.04 mm, P2 r1, only the fillet refined",
                           [*FILLET, *ONE_CONE, *R1_FILLET]),
    # the same with quadratic cells, whose mid-side nodes lie on the arcs (mesh.geometry_degree = 2)
    "curved-4cones-p2-r1": ("4 cones, fillet 0.04 mm, P2 r1 on quadratic cells, only the fillet refined",
                            [*FILLET, *CURVED, "--forces", "1,4"]),
    "curved-1cone-p2-r1": ("1 cone, 1 N, fillet 0.04 mm, P2 r1 on quadratic cells, only the fillet refined",
                           [*FILLET, *CURVED, *ONE_CONE]),
    # global refinement on quadratic cells, the arcs resolved at every rung: 32, 64, 128 elements along each
    "curved-global-4cones": ("4 cones, fillet 0.04 mm, P2 on quadratic cells, 32 x 2^k elements per arc",
                             [*FILLET, *CURVED_GLOBAL, "--forces", "1,4"]),
    "curved-global-1cone": ("1 cone, 1 N, fillet 0.04 mm, P2 on quadratic cells, 32 x 2^k elements per arc",
                            [*FILLET, *CURVED_GLOBAL, *ONE_CONE]),
    "fillet-4cones-farfield": ("4 cones, fillet 0.04 mm, P2 r1, 256 elements along each arc",
                               [*FILLET, *FAR_FIELD, "--forces", "1,4"]),
    "fillet-1cone-farfield": ("1 cone, 1 N, fillet 0.04 mm, P2 r1, 256 elements along each arc",
                              [*FILLET, *ONE_CONE, *FAR_FIELD]),
}
SUMMARY = ("usum_mm", "regions.tissue.seqv_pa", "regions.tissue.seqv_outside_rim_pa",
           "ledger.tissue_seqv_pa_beyond_0p25mm", "ledger.tissue_seqv_pa_beyond_0p5mm", "eptoeqv")


def run_ladder(name: str, out: Path, redo: bool = False) -> dict:
    title, extra = LADDERS[name] if name in LADDERS else STRESS_LADDERS[name]
    common = COMMON if name in LADDERS else []
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "convergence", "paper", *extra, *common,
           "--title", title, "--out", str(out / name), *(["--redo"] if redo else [])]
    print(f"$ {' '.join(cmd[1:])}", flush=True)
    proc = subprocess.run(cmd, cwd=ROOT)
    if proc.returncode not in (0, 3):
        raise SystemExit(f"ledger {name} failed with exit code {proc.returncode}")
    return json.loads((out / name / "ledger.json").read_text())


def summary_rows(name: str, ledger: dict) -> list[dict]:
    rows = []
    for force, per_q in ledger["analysis"].items():
        for rung in ledger["rungs"]:
            row = {"ledger": name, "force_n": float(force), "rung": rung["name"], "dofs": rung["dofs"],
                   "wall_time_s": rung["wall_time_s"], "cpu_time_s": rung.get("cpu_time_s"),
                   "peak_memory_mb": rung["peak_memory_mb"]}
            for path in SUMMARY:
                e = per_q[path]["rungs"].get(rung["name"], {})
                row[path] = e.get("value")
                row[path + ":error_rel"] = e.get("error_rel")
            rows.append(row)
    return rows


def _cell(v, err) -> str:
    if v is None:
        return "-"
    txt = f"{v:.4g}" if abs(v) < 1e4 else f"{v / 1e3:.4g}k"
    return txt + (f" ({100 * err:.2g}%)" if err is not None else "")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/ledger"))
    ap.add_argument("--only", choices=[*LADDERS, *STRESS_LADDERS], action="append",
                    help="run only these ladders (the stress ladders of issue 17 only when named)")
    ap.add_argument("--summary-only", action="store_true", help="solve nothing: summarise the ledgers in OUT")
    ap.add_argument("--redo", action="store_true", help="solve every rung again")
    args = ap.parse_args()
    out = Path(args.out)
    names = args.only or list(LADDERS)
    if args.summary_only:
        ledgers = {name: json.loads((out / name / "ledger.json").read_text()) for name in names
                   if (out / name / "ledger.json").exists()}
    else:
        ledgers = {name: run_ladder(name, out, args.redo) for name in names}
    rows = [r for name, ledger in ledgers.items() for r in summary_rows(name, ledger)]
    header = ["ledger", "F (N)", "rung", "dofs", "wall (s)", "peak MB", "USUM mm", "SEQV tissue", "SEQV out-rim",
              "SEQV >0.25mm", "SEQV >0.5mm", "EPTOEQV"]
    print("\n" + " | ".join(header))
    for r in rows:
        print(" | ".join([r["ledger"], f"{r['force_n']:g}", r["rung"], str(r["dofs"]), f"{r['wall_time_s']:.1f}",
                          f"{r['peak_memory_mb']:.0f}"] + [_cell(r[p], r[p + ":error_rel"]) for p in SUMMARY]))
    within = {name: ledger["usum_within_1_percent"] for name, ledger in ledgers.items()}
    print("\nUSUM within 1 % of the extrapolated value:", json.dumps(within, indent=1))
    write_json(out / "summary.json", {"rows": rows, "usum_within_1_percent": within,
                                      "verdicts": {name: {f: {p["label"]: p["verdict"] for p in per_q.values()}
                                                          for f, per_q in ledger["analysis"].items()}
                                                   for name, ledger in ledgers.items()}})
    write_text(out / "summary.md", "\n\n".join((out / name / "ledger.md").read_text() for name in ledgers))
    print(f"\nwrote {out / 'summary.json'} and {out / 'summary.md'}")


if __name__ == "__main__":
    main()
