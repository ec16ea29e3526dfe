"""Benchmark: each thread (or cone) interface model side by side with tied on the same scene.

Runs ``suture-fem run paper`` (P2, 0-4 N, reports at 1-4 N) for the given cone counts with
``effects.thread_interface`` (``--vary cone``: ``effects.cone_interface``) tied, sliding, frictionless and
coulomb (``--models``), one child process each, in one invocation.
Prints a table and writes JSON: USUM and the thread end's displacement at each reported force, the load share
of the thread and of each cone at the peak, Newton iterations, load steps, cutbacks, CPU seconds and
peak memory.

    .venv/bin/python benchmarks/interfaces.py [--cones 1,4] [--vary thread|cone] [--models tied,sliding]
        [--set KEY=VALUE ...] [--out benchmarks/out/interfaces] [--before COMMIT]

Counts do not depend on the machine's load; CPU seconds do (compare them side by side, as here).
``--before COMMIT`` also runs every case with that commit's code (a git worktree in /var/tmp, as
benchmarks/speed.py makes), each case before then now, back to back, so both see the same load. Under
displacement control (``--set loading.control='"displacement"' --set loading.displacement_mm=5``, P1 or
P2) the force column is the end's reaction. ``--set effects.friction_coefficient=MU`` sets the Coulomb
thread's coefficient (the other models do not read it).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from speed import ROOT, run, worktree  # noqa: E402

MODELS = ("tied", "sliding", "frictionless", "coulomb")


def case(cones: int, model: str, extra: list[str], out: Path, vary: str = "thread", code: Path = ROOT) -> dict:
    """One ramp (with the code at ``code``): its results and costs."""
    args = ["run", "paper", "--set", f"geometry.cones={cones}", "--set", f'effects.{vary}_interface="{model}"',
            "--set", 'output.quantities=["usum","interface"]', "--no-pictures"]
    for kv in extra:
        args += ["--set", kv]
    row = run(code, args, out)
    res = json.loads((out / "results.json").read_text()) if (out / "results.json").is_file() else {}
    reports = res.get("at_forces", [])
    last = reports[-1].get("interface", {}) if reports else {}
    if vary == "cone":  # the cones' largest slip and how many of their nodes have lifted off
        contact = last.get("cone_contact", {})
        slips = [c["slip_max_mm"] for c in contact.get("cones", {}).values()]
        last = {"slip_max_mm": max(slips) if slips else None, "open_nodes": contact.get("open_nodes")}
    return {"cones": cones, "model": model, "code": "now" if code == ROOT else "before", "exit": row["exit"],
            "cpu_s": row["cpu_s"], "peak_mb": row["peak_mb"],
            "newton_iterations": res.get("newton_iterations"), "load_steps": res.get("load_steps"),
            "cutbacks": res.get("cutbacks"),
            "usum_mm": {r["force_n"]: r.get("usum_mm") for r in reports},
            "thread_end_mm": {r["force_n"]: r.get("thread_end_displacement_mm") for r in reports},
            "load_share_n": reports[-1].get("load_share_n") if reports else None,
            "slip_max_mm": last.get("slip_max_mm"), "open_nodes": last.get("open_nodes")}


def main(argv: list[str] | None = None) -> int:
    """Run the cases, print the table, write the JSON."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cones", default="1,4")
    ap.add_argument("--vary", choices=("thread", "cone"), default="thread")
    ap.add_argument("--models", default=",".join(MODELS))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "interfaces"))
    ap.add_argument("--before", default=None, metavar="COMMIT", help="also run each case with this commit's code")
    args = ap.parse_args(argv)
    out = Path(args.out)
    codes = ([worktree(args.before)] if args.before else []) + [ROOT]
    rows = []
    for cones in [int(c) for c in args.cones.split(",")]:
        for model in args.models.split(","):
            for code in codes:
                where = out / ("before" if code != ROOT else "") / f"cones_{cones}_{model}"
                rows.append(case(cones, model, args.set, where, args.vary, code))
    print(f"| code | cones | {args.vary} | exit | USUM at the reports (mm) | force at the last report (N) "
          "| thread share there (N) | cone shares (N) | slip max (mm) | open nodes | Newton its | steps | cutbacks "
          "| CPU s | peak MB |")
    print("| --- " * 15 + "|")
    for r in rows:
        usum = " / ".join(f"{v:.3f}" for v in r["usum_mm"].values() if v is not None)
        shares = r["load_share_n"] or {}
        cones_txt = ", ".join(f"{v:.3f}" for k, v in shares.items() if k != "thread")
        slip = f"{r['slip_max_mm']:.3f}" if r["slip_max_mm"] is not None else "-"
        last = max(r["usum_mm"], default=float("nan"))
        thread = shares.get("thread", float("nan"))
        print(f"| {r['code']} | {r['cones']} | {r['model']} | {r['exit']} | {usum} | {last:.4g} | {thread:.3g} | "
              f"{cones_txt} | {slip} | {r['open_nodes'] if r['open_nodes'] is not None else '-'} | "
              f"{r['newton_iterations']} | {r['load_steps']} | {r['cutbacks']} | "
              f"{r['cpu_s']:.1f} | {r['peak_mb']:.0f} |")
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{args.vary}_interfaces.json").write_text(json.dumps(rows, indent=2))
    print(f"wrote {out / f'{args.vary}_interfaces.json'}")
    return 0 if all(r["exit"] in (0, 3) for r in rows) else 1  # 3: a diagnosed stop, reported in the table


if __name__ == "__main__":
    raise SystemExit(main())
