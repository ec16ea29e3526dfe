"""Benchmark: what each effect costs and changes on the paper scene (issue "Simulate only the effects a scene calls for").

Parts (each run in its own process; wall and CPU time of that process are both recorded, since the
machine may be shared):

* ``rigid``: the paper scene (4 cones, 4 N, degree 2) with an elastic and with a rigid suture: USUM at
  1 / 2 / 3 / 4 N, unknowns solved for, Newton iterations, time.
* ``hold``: inertia on, paper ramp (1 s) and hold (0.2 s), undamped and Rayleigh-damped, against the
  quasi-static answer; plots the thread end's displacement against time (PNG). ``--hold-degree``
  picks the element degree (1 keeps it to minutes; the time step is set by the tissue's ~15 ms mode,
  not by the mesh).
* ``walltime``: the paper scene with only what the paper's result needs (quasi-static, elastic
  suture, displacement formulation, no gravity) against every effect on (inertia with damping, mixed
  u-p, gravity, elastic suture), and the quasi-static answer of the latter for the hold check.

    .venv/bin/python benchmarks/effects.py [--parts rigid hold walltime] [--out benchmarks/out/effects]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.io import write_json  # noqa: E402

#: Mass-proportional damping for the damped hold: alpha = 2 zeta omega with zeta = 0.5 on the tissue's
#: slowest axial mode (period about 15 ms, omega = 420 rad/s).
DAMPING = ["effects.rayleigh_mass_per_s=420"]
EVERY_EFFECT = ["effects.inertia=true", "effects.incompressibility=mixed", "effects.gravity=true", *DAMPING]


def run(label: str, overrides: list[str], tmp: Path) -> dict:
    """`suture-fem run paper` in a fresh process: results.json plus that process's wall and CPU time."""
    out = tmp / label.replace(" ", "_")
    cmd = [sys.executable, "-m", "suture_fem.cli", "run", "paper", *[a for o in overrides for a in ("--set", o)],
           "--out", str(out)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else {}
    res.update(exit_code=proc.returncode, process_wall_s=wall,
               process_cpu_s=(after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), label=label)
    print(f"  {label}: exit {proc.returncode}, {wall:.1f} s wall, {res['process_cpu_s']:.1f} s CPU", flush=True)
    return res


def summary(res: dict) -> dict:
    keys = ("label", "exit_code", "status", "usum_mm", "thread_end_displacement_mm", "dofs", "unknowns",
            "newton_iterations", "load_steps", "cutbacks", "wall_time_s", "process_wall_s", "process_cpu_s")
    out = {k: res.get(k) for k in keys}
    out["usum_mm_at"] = {f"{a['force_n']:g}": a["usum_mm"] for a in res.get("at_forces", [])}
    out["timings_s"] = res.get("timings_s")
    return out


def part_rigid(tmp: Path) -> dict:
    el = run("elastic suture", [], tmp)
    rg = run("rigid suture", ["effects.suture=rigid"], tmp)
    rows = []
    for f, u_el in summary(el)["usum_mm_at"].items():
        u_rg = summary(rg)["usum_mm_at"][f]
        tissue_el = next(a for a in el["at_forces"] if f"{a['force_n']:g}" == f)["regions"]["tissue"]["usum_mm"]
        tissue_rg = next(a for a in rg["at_forces"] if f"{a['force_n']:g}" == f)["regions"]["tissue"]["usum_mm"]
        rows.append({"force_n": float(f), "usum_elastic_mm": u_el, "usum_rigid_mm": u_rg,
                     "usum_rel_diff": (u_rg - u_el) / u_el, "tissue_usum_elastic_mm": tissue_el,
                     "tissue_usum_rigid_mm": tissue_rg, "tissue_usum_rel_diff": (tissue_rg - tissue_el) / tissue_el})
    print("F (N) | USUM elastic | USUM rigid | diff | tissue USUM elastic | rigid | diff")
    for r in rows:
        print(f"{r['force_n']:g} | {r['usum_elastic_mm']:.4f} | {r['usum_rigid_mm']:.4f} | {100 * r['usum_rel_diff']:+.2f} % | "
              f"{r['tissue_usum_elastic_mm']:.4f} | {r['tissue_usum_rigid_mm']:.4f} | {100 * r['tissue_usum_rel_diff']:+.2f} %")
    for s in (summary(el), summary(rg)):
        print(f"{s['label']}: {s['unknowns']} unknowns of {s['dofs']} dofs, {s['newton_iterations']} Newton its, "
              f"{s['wall_time_s']:.1f} s wall (in-run), {s['process_cpu_s']:.1f} s CPU")
    return {"elastic": summary(el), "rigid": summary(rg), "by_force": rows}


def part_hold(tmp: Path, degree: int, out: Path) -> dict:
    base = [f"mesh.degree={degree}", "loading.report_forces_n=[]"]
    qs = run(f"quasi-static P{degree}", base, tmp)
    undamped = run(f"inertia undamped P{degree}", base + ["effects.inertia=true"], tmp)
    damped = run(f"inertia damped P{degree}", base + ["effects.inertia=true", *DAMPING], tmp)
    ref = qs["usum_mm"]
    rec = {"quasi_static_usum_mm": ref, "degree": degree, "damping": DAMPING}
    for name, r in (("undamped", undamped), ("damped", damped)):
        hist = r.get("time_history", [])
        hold = [h for h in hist if h[0] >= 1.0 - 1e-12]
        rec[name] = {**summary(r), "end_of_hold_usum_mm": r.get("usum_mm"),
                     "end_rel_diff": (r["usum_mm"] - ref) / ref if r.get("usum_mm") else None,
                     "hold_min_mm": min(h[2] for h in hold) if hold else None,
                     "hold_max_mm": max(h[2] for h in hold) if hold else None, "time_history": hist}
        print(f"{name}: end of hold USUM {r.get('usum_mm')} mm vs quasi-static {ref:.5f} mm "
              f"({100 * rec[name]['end_rel_diff']:+.3f} %), thread end over the hold "
              f"{rec[name]['hold_min_mm']:.5f} .. {rec[name]['hold_max_mm']:.5f} mm")
    plot(rec, out.with_suffix(".png"))
    return rec


def plot(rec: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, window in zip(axes, ((0.0, 1.2), (0.95, 1.2))):
        for name, style in (("undamped", "-"), ("damped", "--")):
            h = rec[name]["time_history"]
            ax.plot([p[0] for p in h], [p[2] for p in h], style, label=name)
        ax.axhline(rec["quasi_static_usum_mm"], color="k", lw=0.8, label="quasi-static at 4 N")
        ax.set_xlim(*window)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("thread end axial displacement (mm)")
        ax.grid(alpha=0.3)
    lo = min(rec[n]["hold_min_mm"] for n in ("undamped", "damped"))
    hi = max(rec[n]["hold_max_mm"] for n in ("undamped", "damped"))
    pad = 0.2 * (hi - lo) + 1e-3
    axes[1].set_ylim(lo - pad, hi + pad)
    axes[0].legend()
    axes[1].set_title("ramp end and hold (zoom)")
    fig.suptitle(f"Paper scene (P{rec['degree']}), ramp 1 s to 4 N, hold 0.2 s: inertia, with and without Rayleigh damping")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def part_walltime(tmp: Path) -> dict:
    paper = run("only what the paper needs", [], tmp)
    every = run("every effect on", EVERY_EFFECT, tmp)
    every_qs = run("every effect but inertia (quasi-static reference)",
                   ["effects.incompressibility=mixed", "effects.gravity=true"], tmp)
    rec = {"paper": summary(paper), "every": summary(every), "every_quasi_static": summary(every_qs)}
    if every.get("usum_mm") and every_qs.get("usum_mm"):
        rec["every_end_of_hold_vs_quasi_static"] = (every["usum_mm"] - every_qs["usum_mm"]) / every_qs["usum_mm"]
    print("configuration | unknowns | Newton its | steps | wall (s) | CPU (s) | USUM (mm)")
    for s in rec.values():
        if isinstance(s, dict):
            print(f"{s['label']} | {s['unknowns']} | {s['newton_iterations']} | {s['load_steps']} | "
                  f"{s['process_wall_s']:.1f} | {s['process_cpu_s']:.1f} | {s['usum_mm']}")
    return rec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parts", nargs="+", default=["rigid", "hold", "walltime"], choices=["rigid", "hold", "walltime"])
    ap.add_argument("--hold-degree", type=int, default=1, choices=[1, 2])
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/effects"), help="output path without suffix")
    args = ap.parse_args()
    out = Path(args.out)
    path = out.with_suffix(".json")
    record = json.loads(path.read_text()) if path.is_file() else {}
    with tempfile.TemporaryDirectory() as tmp:
        for part in args.parts:
            print(f"== {part}", flush=True)
            if part == "rigid":
                record["rigid"] = part_rigid(Path(tmp))
            elif part == "hold":
                record["hold"] = part_hold(Path(tmp), args.hold_degree, out)
            else:
                record["walltime"] = part_walltime(Path(tmp))
            write_json(path, record)


if __name__ == "__main__":
    main()
