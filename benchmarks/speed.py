"""Benchmark: the cost of one paper answer and of the reproduce study, now against the commit before issue 14.

Both codes run the same commands in the same invocation, one after the other, each command in its
own process (CPU seconds and peak memory from that process's rusage): the commit before issue 14
from a git worktree this script creates in /var/tmp (PYTHONPATH pointing at it), and this tree.
Prints a table and writes JSON: CPU and wall seconds, Newton iterations per ramp, factorisation
seconds per iteration (MUMPS, from the linear-solve time), assembly seconds, peak memory, USUM at
4 N and its error against the ledger's converged value (docs/ledger.md), and the load average.

    .venv/bin/python benchmarks/speed.py [--cases run-P2,run-P1,reproduce] [--before COMMIT]
        [--out benchmarks/out/speed] [--peer | --peer-only] [--peer-degree 1|2]

Wall times swing with the load of the machine; compare the CPU seconds and the iteration counts.
``--peer`` also runs the paper scene at P1 in FElupe beside ours, each in its own child process, and
prints the CPU ratio and the USUM difference (benchmarks/peer_compare.py, docs/peer.md; needs the optional
extra ``peer``); ``--peer-only`` runs only that comparison (no before/after cases, no worktree).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: USUM at 4 N, Richardson limit of the P1 ladder (docs/ledger.md, sharp rims)
USUM_CONVERGED_MM = 4.698
CASES = {
    "run-P2": ["run", "paper"],
    "run-P1": ["run", "paper", "--set", "mesh.degree=1"],
    "reproduce": ["reproduce", "--no-pictures", "--calibrate", "none"],  # --jobs: min(cores, 4) by default
    "reproduce-calibrated": ["reproduce", "--no-pictures"],
}
#: The same work in the commit before issue 14, where the arguments differ (None: no such command there).
#: Its `reproduce` had no calibration by default (issue 18 added --calibrate KEY) and ran P2 r0 for every cone count.
BEFORE_ARGS = {"reproduce": ["reproduce", "--no-pictures"], "reproduce-calibrated": None}


def before_commit(explicit: str | None) -> str:
    """The parent of the first commit whose message starts with 'Issue 14' (or ``explicit``)."""
    if explicit:
        return explicit
    log = subprocess.run(["git", "-C", str(ROOT), "log", "--format=%H %s", "--reverse"], capture_output=True,
                         text=True, check=True).stdout.splitlines()
    first = next((line.split()[0] for line in log if line.split(" ", 1)[1].startswith("Issue 14")), None)
    if first is None:
        raise SystemExit("speed.py: no 'Issue 14' commit yet; pass --before COMMIT")
    return subprocess.run(["git", "-C", str(ROOT), "rev-parse", first + "^"], capture_output=True, text=True,
                          check=True).stdout.strip()


def worktree(commit: str) -> Path:
    """A detached worktree of ``commit`` in /var/tmp (created once, reused)."""
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", commit], capture_output=True, text=True,
                            check=True).stdout.strip()
    path = Path("/var/tmp") / f"suture_fem-speed-{commit[:10]}"
    if not (path / "suture_fem").is_dir():
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(path), commit], check=True,
                       capture_output=True)
    return path


def run(code: Path, args: list[str], out: Path) -> dict:
    """One command of ``code`` in its own process: its rusage, wall time and results."""
    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1")
    cmd = [sys.executable, "-P", "-m", "suture_fem.cli", *args,
           "--out", str(out)]
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=str(code), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    row = {"exit": os.waitstatus_to_exitcode(status), "cpu_s": usage.ru_utime + usage.ru_stime, "wall_s": wall,
           "peak_mb": usage.ru_maxrss / 1024, "load_before": load, "load_after": os.getloadavg()[0]}
    if row["exit"] not in (0, 3):
        row["error"] = err[-800:]
    row.update(_results(out))
    return row


def _results(out: Path) -> dict:
    files = [out / "results.json"] if (out / "results.json").is_file() else sorted(out.glob("cones_*/results.json"))
    ramps = [json.loads(f.read_text()) for f in files]
    if not ramps:
        return {}
    its = [r.get("newton_iterations") for r in ramps]
    timings = [r.get("timings_s", {}) for r in ramps]
    linear = sum(t.get("linear_solve", 0.0) for t in timings)
    newton = sum(t.get("newton_total", 0.0) for t in timings)
    usum = [r.get("usum_mm") for r in ramps]
    row = {"newton_its_per_ramp": its, "assembly_s": sum(t.get("assembly", 0.0) for t in timings),
           "linear_s_per_it": linear / max(sum(i or 0 for i in its), 1),
           "newton_s_per_it": newton / max(sum(i or 0 for i in its), 1), "usum_mm": usum,
           "unknowns": [r.get("unknowns") for r in ramps]}
    if len(usum) == 1 and usum[0] is not None:
        row["usum_error_rel"] = usum[0] / USUM_CONVERGED_MM - 1.0
    if len(ramps) > 1:
        row.update(_reproduce(out, ramps))
    return row


def _reproduce(out: Path, ramps: list[dict]) -> dict:
    """reproduce: the ramps' CPU (comparison.json) and each USUM's error against the mesh-converged value.

    The converged values are the references of studies/reproduce/rungs.py (benchmarks/reproduce_rungs.py),
    measured on the uncalibrated scene: a calibrated run's USUM has its rung's estimated error instead.
    """
    sys.path.insert(0, str(ROOT))
    from suture_fem.studies.reproduce.rungs import RUNGS

    cmp = out / "comparison.json"
    info = json.loads(cmp.read_text()).get("run", {}) if cmp.is_file() else {}
    errors = {}
    for r in ramps:
        n, calibrated = r["scene"]["geometry"]["cones"], r["scene"]["materials"].get("tissue_scale", 1.0) != 1.0
        for rec in r.get("at_forces", []):
            f = round(rec["force_n"], 6)
            ref = RUNGS[n].usum_reference_mm.get(f) if n in RUNGS else None
            if calibrated:
                errors[f"{n} cones {f:g} N"] = RUNGS[n].usum_error.get(f) if n in RUNGS else None
            elif ref:
                errors[f"{n} cones {f:g} N"] = rec["usum_mm"] / ref - 1.0
    worst = max((abs(e) for e in errors.values() if e is not None), default=None)
    return {"ramps_cpu_s": info.get("ramps_cpu_time_s"), "jobs": info.get("jobs", 1), "usum_errors_rel": errors,
            "usum_error_rel_max": worst, "errors_are": "estimated (calibrated run: the rung's uncalibrated estimate)"
            if any(r["scene"]["materials"].get("tissue_scale", 1.0) != 1.0 for r in ramps) else "measured"}


def table(rows: list[dict]) -> str:
    head = ("| case | code | CPU (s) | wall (s) | Newton its per ramp | wall s per it (linear solve) | "
            "wall s per it (Newton) | assembly, wall (s) | peak (MB) | USUM (mm) | error vs converged | load |\n"
            + "| --- " * 12 + "|\n")
    body = ""
    for r in rows:
        usum = ", ".join(f"{u:.6f}" for u in r.get("usum_mm", []) if u is not None)
        err = f"{100 * r['usum_error_rel']:.3f} %" if "usum_error_rel" in r else "-"
        body += (f"| {r['case']} | {r['code']} | {r['cpu_s']:.1f} | {r['wall_s']:.1f} | {r.get('newton_its_per_ramp')} "
                 f"| {r.get('linear_s_per_it', 0):.3f} | {r.get('newton_s_per_it', 0):.3f} "
                 f"| {r.get('assembly_s', 0):.1f} "
                 f"| {r['peak_mb']:.0f} | {usum} | {err} | {r['load_before']:.1f} / {r['load_after']:.1f} |\n")
    return head + body


def peer(code: Path, degree: int = 1) -> tuple[list[dict], str]:
    """Ours (``code``) and FElupe on the same mesh of the paper scene, side by side (benchmarks/peer_compare.py)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import peer_compare

    with tempfile.TemporaryDirectory() as tmp:
        return peer_compare.compare(code, Path(tmp), degree)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="run-P2,run-P1,reproduce", help=f"comma-separated, of {', '.join(CASES)}")
    ap.add_argument("--before", default=None, help="the commit to compare with (default: the one before issue 14)")
    ap.add_argument("--now", default=None,
                    help="a commit to measure as 'now' (a worktree too) instead of this working tree, whose "
                    "uncommitted changes of others would enter the measurement")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/speed"), help="output path without suffix")
    ap.add_argument("--peer", action="store_true",
                    help="also solve the paper scene in FElupe beside ours (benchmarks/peer_compare.py)")
    ap.add_argument("--peer-only", action="store_true", help="only the FElupe comparison (no before/after cases)")
    ap.add_argument("--peer-degree", type=int, choices=(1, 2), default=1,
                    help="the peer comparison's degree (2: FElupe with its quadratic triangle corrected)")
    args = ap.parse_args()
    if args.peer_only:
        rows, text = peer(worktree(args.now) if args.now else ROOT, args.peer_degree)
        print(text)
        out = Path(args.out) if args.out != ap.get_default("out") else ROOT / "benchmarks/out/peer"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.with_suffix(".json").write_text(json.dumps({"peer": rows}, indent=1))
        out.with_suffix(".md").write_text(text + "\n")
        return
    before = before_commit(args.before)
    codes = {"before": worktree(before), "now": worktree(args.now) if args.now else ROOT}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in args.cases.split(","):
            for name, code in codes.items():
                args_ = BEFORE_ARGS.get(case, CASES[case]) if name == "before" else CASES[case]
                if args_ is None:
                    continue
                row = {"case": case, "code": name, **run(code, args_, Path(tmp) / f"{case}-{name}")}
                rows.append(row)
                print(f"{case} {name}: {row['cpu_s']:.1f} s CPU, its {row.get('newton_its_per_ramp')}", flush=True)
            a, b = rows[-2], rows[-1]
            if a["case"] == b["case"] and a.get("usum_mm") and b.get("usum_mm"):
                row["usum_change_rel"] = [y / x - 1.0 for x, y in zip(a["usum_mm"], b["usum_mm"]) if x and y]
    text = table(rows)
    for r in rows:
        if "usum_change_rel" in r:
            text += f"\n{r['case']}: USUM now / before - 1 = {', '.join(f'{c:.1e}' for c in r['usum_change_rel'])}"
        if r.get("usum_errors_rel"):
            errs = ", ".join(f"{k} {100 * e:+.2f} %" for k, e in r["usum_errors_rel"].items() if e is not None)
            text += (f"\n{r['case']} {r['code']}: the ramps {r['ramps_cpu_s'] or float('nan'):.1f} s CPU "
                     f"({r['jobs']} job(s)); USUM error vs mesh-converged ({r['errors_are']}): {errs}")
    peer_rows = None
    if args.peer:
        peer_rows, peer_text = peer(codes["now"], args.peer_degree)
        text += f"\n\nFElupe peer (paper scene, P{args.peer_degree}, USUM only, same mesh):\n\n" + peer_text
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps({"before": before, "rows": rows, "peer": peer_rows}, indent=1))
    out.with_suffix(".md").write_text(text + "\n")


if __name__ == "__main__":
    main()
