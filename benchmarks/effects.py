"""Benchmark: what each effect costs and changes on the paper scene.

From the issue "Simulate only the effects a scene calls for".

Parts (each run in its own process; wall and CPU time of that process are both recorded, since the
machine may be shared):

* ``rigid``: the paper scene (4 cones, 4 N, degree 2) with an elastic and with a rigid suture: USUM at
  1 / 2 / 3 / 4 N, unknowns solved for, Newton iterations, time.
* ``hold``: inertia on, undamped and Rayleigh-damped, against the quasi-static answer, for two load
  histories: the paper's (ramp 1 s to 4 N, hold 0.2 s) and a jerk (ramp 20 ms to 1 N, hold 0.2 s,
  0.5 ms steps) that sets the thread end ringing (period about 3.7 ms); plots the thread end's
  displacement against time (PNG). ``--hold-degree`` picks the element degree (1 keeps it to
  minutes; the time step is set by that ringing, not by the mesh).
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

from suture_fem.support.io import write_json  # noqa: E402

#: Mass-proportional damping for the damped hold. The thread end rings with a period of about 3.7 ms
#: (omega = 1700 rad/s, measured by the jerk history with 0.5 ms steps): alpha = 420/s gives a damping
#: ratio alpha / (2 omega) = 0.12 there, an e-folding time 2 / alpha = 5 ms.
DAMPING = ["effects.rayleigh_mass_per_s=420"]
EVERY_EFFECT = ["effects.inertia=true", "effects.incompressibility=mixed", "effects.gravity=true", *DAMPING]


def run(label: str, overrides: list[str], tmp: Path) -> dict:
    """`suture-fem run paper` in a fresh process: results.json plus that process's wall and CPU time."""
    out = tmp / label.replace(" ", "_")
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", "run", "paper", *[a for o in overrides for a in ("--set", o)],
           "--out", str(out)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else {}
    res.update(exit_code=proc.returncode, process_wall_s=wall,
               process_cpu_s=(after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), label=label,
               log_tail=proc.stderr.splitlines()[-40:])  # the run folder is temporary: keep how it ended
    print(f"  {label}: exit {proc.returncode}, {wall:.1f} s wall, {res['process_cpu_s']:.1f} s CPU", flush=True)
    return res


def summary(res: dict) -> dict:
    keys = ("label", "exit_code", "status", "diagnosis", "force_reached_n", "usum_mm", "thread_end_displacement_mm",
            "dofs", "unknowns", "newton_iterations", "load_steps", "cutbacks", "domain_rejections", "residual_floor_n",
            "solves_at_residual_floor", "wall_time_s",
            "process_wall_s", "process_cpu_s", "log_tail")
    out = {k: res.get(k) for k in keys}
    if res.get("time_history"):
        out["time_reached_s"] = res["time_history"][-1][0]
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
        print(f"{r['force_n']:g} | {r['usum_elastic_mm']:.4f} | {r['usum_rigid_mm']:.4f} | "
              f"{100 * r['usum_rel_diff']:+.2f} % | {r['tissue_usum_elastic_mm']:.4f} | "
              f"{r['tissue_usum_rigid_mm']:.4f} | {100 * r['tissue_usum_rel_diff']:+.2f} %")
    for s in (summary(el), summary(rg)):
        print(f"{s['label']}: {s['unknowns']} unknowns of {s['dofs']} dofs, {s['newton_iterations']} Newton its, "
              f"{s['wall_time_s']:.1f} s wall (in-run), {s['process_cpu_s']:.1f} s CPU")
    return {"elastic": summary(el), "rigid": summary(rg), "by_force": rows}


HISTORIES = {
    "paper ramp": ["loading.ramp_s=1.0", "loading.hold_s=0.2"],
    # 0.5 ms steps: about 30 per period of the tissue's slowest axial mode, so the ringing is resolved
    "jerk": ["loading.ramp_s=0.02", "loading.hold_s=0.2", "loading.force_n=1.0", "effects.time_step_s=0.0005"],
}


def part_hold(tmp: Path, degree: int, names: list[str], done: dict) -> dict:
    return {**done, **{name: hold_history(tmp, degree, name, HISTORIES[name]) for name in names}}


def hold_history(tmp: Path, degree: int, name: str, extra: list[str]) -> dict:
    base = [f"mesh.degree={degree}", "loading.report_forces_n=[]", *extra]
    qs = run(f"{name}: quasi-static P{degree}", base, tmp)
    undamped = run(f"{name}: inertia undamped P{degree}", base + ["effects.inertia=true"], tmp)
    damped = run(f"{name}: inertia damped P{degree}", base + ["effects.inertia=true", *DAMPING], tmp)
    ref = qs["usum_mm"]
    rec = {"history": extra, "quasi_static_usum_mm": ref, "degree": degree, "damping": DAMPING,
           "ramp_s": float(qs["scene"]["loading"]["ramp_s"]), "force_n": qs["applied_force_n"],
           "time_step_s": float(qs["scene"]["effects"]["time_step_s"])}
    for name, r in (("undamped", undamped), ("damped", damped)):
        hist = r.get("time_history", [])
        hold = [h for h in hist if h[0] >= rec["ramp_s"] - 1e-12]
        rec[name] = {**summary(r), "end_of_hold_usum_mm": r.get("usum_mm"),
                     "end_rel_diff": (r["usum_mm"] - ref) / ref if r.get("usum_mm") else None,
                     "hold_min_mm": min(h[2] for h in hold) if hold else None,
                     "hold_max_mm": max(h[2] for h in hold) if hold else None, "time_history": hist}
        print(f"  {name}: end of hold USUM {r.get('usum_mm')} mm vs quasi-static {ref:.5f} mm "
              f"({100 * rec[name]['end_rel_diff']:+.3f} %), thread end over the hold "
              f"{rec[name]['hold_min_mm']:.5f} .. {rec[name]['hold_max_mm']:.5f} mm")
    return rec


def plot(hold: dict, path: Path) -> None:
    """Thread end displacement against time: one row per load history, whole run and hold zoom."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(hold), 2, figsize=(12, 4 * len(hold)), squeeze=False)
    for row, (name, rec) in zip(axes, hold.items()):
        end = max(p[0] for p in rec["undamped"]["time_history"])
        for ax, window in zip(row, ((0.0, end), (0.8 * rec["ramp_s"], end))):
            for label, style in (("undamped", "-"), ("damped", "--")):
                h = rec[label]["time_history"]
                ax.plot([p[0] for p in h], [p[2] for p in h], style, label=label)
            ax.axhline(rec["quasi_static_usum_mm"], color="k", lw=0.8, label=f"quasi-static at {rec['force_n']:g} N")
            ax.set_xlim(*window)
            ax.set_xlabel("time (s)")
            ax.set_ylabel("thread end axial displacement (mm)")
            ax.grid(alpha=0.3)
        lo = min(rec[n]["hold_min_mm"] for n in ("undamped", "damped"))
        hi = max(rec[n]["hold_max_mm"] for n in ("undamped", "damped"))
        pad = 0.2 * (hi - lo) + 1e-4
        row[1].set_ylim(lo - pad, hi + pad)
        row[0].legend()
        row[0].set_title(f"{name}: ramp {rec['ramp_s']:g} s to {rec['force_n']:g} N, hold 0.2 s "
                         f"(P{rec['degree']}, dt = {1e3 * rec['time_step_s']:g} ms)")
        row[1].set_title("end of ramp and hold (zoom)")
    fig.suptitle("Paper geometry with inertia: thread end displacement, undamped and Rayleigh-damped\n"
                 f"(alpha = {DAMPING[0].split('=')[1]}/s mass-proportional); generalized-alpha, rho_inf = 0.8")
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
    if every.get("status") == "converged" and every_qs.get("status") == "converged":
        rec["every_end_of_hold_vs_quasi_static"] = (every["usum_mm"] - every_qs["usum_mm"]) / every_qs["usum_mm"]
    print("configuration | status | unknowns | Newton its | steps | cutbacks | wall (s) | CPU (s) | USUM (mm)")
    for s in rec.values():
        if isinstance(s, dict):
            print(f"{s['label']} | {s['status']} | {s['unknowns']} | {s['newton_iterations']} | {s['load_steps']} | "
                  f"{s['cutbacks']} | {s['process_wall_s']:.1f} | {s['process_cpu_s']:.1f} | {s['usum_mm']}")
            if s.get("diagnosis"):
                print(f"  stopped: {s['diagnosis']}")
    return rec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parts", nargs="+", default=["rigid", "hold", "walltime"], choices=["rigid", "hold", "walltime"])
    ap.add_argument("--hold-degree", type=int, default=1, choices=[1, 2])
    ap.add_argument("--histories", nargs="+", default=list(HISTORIES), choices=list(HISTORIES),
                    help="load histories of the hold part to (re)run; the others are kept from the JSON")
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
                record["hold"] = part_hold(Path(tmp), args.hold_degree, args.histories, record.get("hold", {}))
                plot(record["hold"], out.with_suffix(".png"))
            else:
                record["walltime"] = part_walltime(Path(tmp))
            write_json(path, record)


if __name__ == "__main__":
    main()
