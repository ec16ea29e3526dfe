"""Benchmark: the cost of one paper answer and of the reproduce study, now against the commit before issue 14.

Both codes run the same commands in the same invocation, one after the other, each command in its
own process (CPU seconds and peak memory from that process's rusage): the commit before issue 14
from a git worktree this script creates in /var/tmp (PYTHONPATH pointing at it), and this tree.
Prints a table and writes JSON: CPU and wall seconds, Newton iterations per ramp, factorisation
seconds per iteration (MUMPS, from the linear-solve time), assembly seconds, peak memory, USUM at
4 N and its error against the ledger's converged value (docs/ledger.md), and the load average.

    .venv/bin/python benchmarks/speed.py [--cases run-P2,run-P1,reproduce] [--before COMMIT]
        [--out benchmarks/out/speed]

Wall times swing with the load of the machine; compare the CPU seconds and the iteration counts.
``--peer`` also runs the paper scene at P1 in FElupe beside ours, each in its own child process, and
prints the CPU ratio and the USUM difference (benchmarks/peer_felupe.py, docs/peer.md; needs the optional
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
    "reproduce": ["reproduce", "--no-pictures"],
}


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
    return row


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


def peer(code: Path) -> tuple[list[dict], str]:
    """Ours (``code``) and FElupe on the same P1 mesh of the paper scene, side by side (benchmarks/peer_felupe.py)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import peer_felupe

    with tempfile.TemporaryDirectory() as tmp:
        return peer_felupe.compare(code, Path(tmp))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default="run-P2,run-P1,reproduce", help=f"comma-separated, of {', '.join(CASES)}")
    ap.add_argument("--before", default=None, help="the commit to compare with (default: the one before issue 14)")
    ap.add_argument("--now", default=None,
                    help="a commit to measure as 'now' (a worktree too) instead of this working tree, whose "
                    "uncommitted changes of others would enter the measurement")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/speed"), help="output path without suffix")
    ap.add_argument("--peer", action="store_true",
                    help="also solve the paper scene at P1 in FElupe beside ours (benchmarks/peer_felupe.py)")
    ap.add_argument("--peer-only", action="store_true", help="only the FElupe comparison (no before/after cases)")
    args = ap.parse_args()
    if args.peer_only:
        rows, text = peer(worktree(args.now) if args.now else ROOT)
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
                row = {"case": case, "code": name, **run(code, CASES[case], Path(tmp) / f"{case}-{name}")}
                rows.append(row)
                print(f"{case} {name}: {row['cpu_s']:.1f} s CPU, its {row.get('newton_its_per_ramp')}", flush=True)
            a, b = rows[-2], rows[-1]
            if a.get("usum_mm") and b.get("usum_mm"):
                row["usum_change_rel"] = [y / x - 1.0 for x, y in zip(a["usum_mm"], b["usum_mm"]) if x and y]
    text = table(rows)
    for r in rows:
        if "usum_change_rel" in r:
            text += f"\n{r['case']}: USUM now / before - 1 = {', '.join(f'{c:.1e}' for c in r['usum_change_rel'])}"
    peer_rows = None
    if args.peer:
        peer_rows, peer_text = peer(codes["now"])
        text += "\n\nFElupe peer (paper scene, P1, USUM only, same mesh):\n\n" + peer_text
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix(".json").write_text(json.dumps({"before": before, "rows": rows, "peer": peer_rows}, indent=1))
    out.with_suffix(".md").write_text(text + "\n")


if __name__ == "__main__":
    main()
