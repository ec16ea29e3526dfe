"""Benchmark: the mesh rung of each cone count of `suture-fem reproduce`, from measured ladders.

For 1-4 cones of the built-in scene `paper_reproduction` (uncalibrated), runs `suture-fem convergence`
(every rung in its own process; rungs already solved in OUT are reused, so an interrupted run resumes):

* 1 and 4 cones: degree 1 at refinements 0, 1, 2 and degree 2 at 0 (and 1 where solved);
* 2 and 3 cones: degree 1 at refinements 0, 1 and degree 2 at 0;
* 1 cone with `mesh.size_suture_mm = 0.1` (the issue's candidate): degree 1 at refinements 0, 1; with
  0.075 mm: degree 1 at refinement 0 (and the same at 4 cones).

The reference (the mesh-converged USUM) at each cone count and force is the Richardson limit of the
degree-1 ladder r0-r2 (observed order, `suture_fem.studies.convergence.richardson`) where that ladder
has three rungs and converges, else the finest degree-2 rung; its uncertainty is the difference
between the two where both exist (else the P2 r0 -> r1 change, else the largest such difference
found at another cone count). Each rung's error is (USUM - reference) / reference; the chosen rung
is the cheapest (CPU seconds of its ramp) whose largest |error| at 1-4 N plus the reference's
uncertainty is at most 1 %. Prints the table and the chosen rungs (as the data of
`suture_fem/studies/reproduce/rungs.py`), writes OUT/summary.json and OUT/summary.md.

    .venv/bin/python benchmarks/reproduce_rungs.py [--out benchmarks/out/reproduce_rungs] [--summary-only]

The full run takes about an hour of CPU (the 4-cone degree-1 refinement-2 rung alone 2.5 min of CPU,
168k dofs); wall time on a shared 2-core machine is several times that.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.studies.convergence.richardson import richardson  # noqa: E402
from suture_fem.support.io import write_json, write_text  # noqa: E402

FORCES = (1.0, 2.0, 3.0, 4.0)
BOUND = 0.01  # USUM within 1 % of the mesh-converged value
#: folder -> (cones, extra arguments of `suture-fem convergence paper_reproduction`)
LADDERS = {
    "cones_4": (4, ["--degrees", "1,2", "--refinements", "0,1,2", "--cap", "2=0"]),
    "cones_1": (1, ["--degrees", "1,2", "--refinements", "0,1,2", "--cap", "2=1"]),
    "cones_1_suture0.1": (1, ["--set", "mesh.size_suture_mm=0.1", "--degrees", "1", "--refinements", "0,1"]),
    "cones_1_suture0.075": (1, ["--set", "mesh.size_suture_mm=0.075", "--degrees", "1", "--refinements", "0"]),
    "cones_4_suture0.075": (4, ["--set", "mesh.size_suture_mm=0.075", "--degrees", "1", "--refinements", "0"]),
    "cones_2": (2, ["--degrees", "1,2", "--refinements", "0,1", "--cap", "2=0"]),
    "cones_3": (3, ["--degrees", "1,2", "--refinements", "0,1", "--cap", "2=0"]),
}


def run_ladder(name: str, out: Path) -> None:
    cones, extra = LADDERS[name]
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "convergence", "paper_reproduction", "--set",
           f"geometry.cones={cones}", *extra, "--forces", ",".join(f"{f:g}" for f in FORCES), "--out", str(out / name)]
    print(f"$ {' '.join(cmd[1:])}", flush=True)
    if subprocess.run(cmd, cwd=ROOT).returncode not in (0, 3):
        raise SystemExit(f"ladder {name} failed")


def rungs_of(name: str, out: Path) -> list[dict]:
    """Every solved rung of a ladder: label, mesh keys, CPU seconds, dofs, USUM at each force."""
    rows = []
    for path in sorted((out / name / "rungs").glob("*/rung.json")):
        d = json.loads(path.read_text())
        if d.get("status") not in ("converged", "stopped"):  # a stopped ramp still gives the forces it reached
            continue
        mesh = d["scene"]["mesh"]
        label = f"P{d['degree']} r{d['refinement']}" + (f", suture {mesh['size_suture_mm']:g} mm"
                                                          if "suture" in name else "")
        usum = {float(f): v["usum_mm"] for f, v in d["values"].items() if float(f) in FORCES}
        rows.append({"ladder": name, "cones": d["scene"]["geometry"]["cones"], "rung": label, "degree": d["degree"],
                     "refinement": d["refinement"], "size_suture_mm": mesh["size_suture_mm"], "dofs": d["dofs"],
                     "cpu_s": d["cpu_time_s"], "newton_iterations": d["newton_iterations"], "usum_mm": usum,
                     "status": d["status"]})
    return rows


def references(rows: list[dict], cones: int) -> dict[float, dict]:
    """The mesh-converged USUM at every force, how it was obtained, and its uncertainty (relative)."""
    mine = [r for r in rows if r["cones"] == cones and "suture" not in r["ladder"]]
    p1 = sorted((r for r in mine if r["degree"] == 1), key=lambda r: r["refinement"])
    p2 = sorted((r for r in mine if r["degree"] == 2), key=lambda r: r["refinement"])
    out = {}
    p2 = [r for r in p2 if len(r["usum_mm"]) == len(FORCES)]
    for f in FORCES:
        ladder = [r["usum_mm"][f] for r in p1 if f in r["usum_mm"]]
        est = richardson(ladder) if len(ladder) >= 3 else None
        finest_p2 = p2[-1]["usum_mm"][f] if p2 else None
        if est is not None and est.converging:
            ref, how = est.limit, f"Richardson limit of P1 r0-r2 (order {est.order:.2f})"
        elif not p2:
            return {}  # not solved yet
        else:
            ref, how = finest_p2, f"finest P2 rung ({p2[-1]['rung']})"
        spread = [abs(est.limit - finest_p2) / ref] if est is not None and est.converging and finest_p2 else []
        if len(p2) >= 2:
            spread.append(abs(p2[-1]["usum_mm"][f] - p2[-2]["usum_mm"][f]) / ref)
        out[f] = {"usum_mm": ref, "how": how, "uncertainty_rel": max(spread) if spread else None}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/reproduce_rungs"))
    ap.add_argument("--summary-only", action="store_true", help="solve nothing: summarise the rungs in OUT")
    args = ap.parse_args()
    out = Path(args.out)
    if not args.summary_only:
        for name in LADDERS:
            run_ladder(name, out)
    rows = [r for name in LADDERS for r in rungs_of(name, out)]
    refs = {n: references(rows, n) for n in sorted({r["cones"] for r in rows})}
    refs = {n: ref for n, ref in refs.items() if ref}
    rows = [r for r in rows if r["cones"] in refs]
    known = [v["uncertainty_rel"] for ref in refs.values() for v in ref.values() if v["uncertainty_rel"] is not None]
    fallback = max(known, default=0.0)
    lines = ["| cones | rung | dofs | CPU (s) | Newton its | USUM 1 N (mm) | error at 1 / 2 / 3 / 4 N | within 1 % |",
             "| --- | --- | ---: | ---: | ---: | ---: | --- | --- |"]
    chosen = {}
    for r in sorted(rows, key=lambda r: (r["cones"], r["cpu_s"])):
        ref = refs[r["cones"]]
        if len(r["usum_mm"]) < len(FORCES):
            lines.append(f"| {r['cones']} | {r['rung']} | {r['dofs']:,} | {r['cpu_s']:.1f} | "
                         f"{r['newton_iterations']} | {r['usum_mm'][1.0]:.4f} | {r['status']} before 4 N | - |")
            continue
        r["error_rel"] = {f: r["usum_mm"][f] / ref[f]["usum_mm"] - 1.0 for f in FORCES}
        unc = max(v["uncertainty_rel"] if v["uncertainty_rel"] is not None else fallback for v in ref.values())
        r["within"] = max(abs(e) for e in r["error_rel"].values()) + unc <= BOUND
        if r["within"] and r["cones"] not in chosen:
            chosen[r["cones"]] = r
        errs = " / ".join(f"{100 * e:+.2f} %" for e in r["error_rel"].values())
        lines.append(f"| {r['cones']} | {r['rung']} | {r['dofs']:,} | {r['cpu_s']:.1f} | {r['newton_iterations']} | "
                     f"{r['usum_mm'][1.0]:.4f} | {errs} | {'yes' if r['within'] else 'no'} |")
    lines += ["", "| cones | force | reference USUM (mm) | how | uncertainty |", "| --- | --- | ---: | --- | ---: |"]
    for n, ref in refs.items():
        for f, v in ref.items():
            unc = (f"{100 * fallback:.2f} % (the largest found at another cone count)" if v["uncertainty_rel"] is None
                   else f"{100 * v['uncertainty_rel']:.2f} %")
            lines.append(f"| {n} | {f:g} N | {v['usum_mm']:.4f} | {v['how']} | {unc} |")
    lines += ["", "Chosen (cheapest with |error| + reference uncertainty <= 1 % at 1-4 N):"]
    for n, r in sorted(chosen.items()):
        errs = ", ".join(f"{f:g} N {100 * e:+.2f} %" for f, e in r["error_rel"].items())
        lines.append(f"- {n} cones: {r['rung']} ({r['cpu_s']:.1f} s CPU in the ladder), errors {errs}")
    text = "\n".join(lines)
    print(text)
    write_json(out / "summary.json", {"rows": rows, "references": refs, "chosen": chosen,
                                      "reference_uncertainty_fallback": fallback})
    write_text(out / "summary.md", text + "\n")
    print(f"\nwrote {out / 'summary.json'} and {out / 'summary.md'}")


if __name__ == "__main__":
    main()
