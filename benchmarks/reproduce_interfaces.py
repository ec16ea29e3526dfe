"""Benchmark: the paper's study under each thread (or cone) interface model, side by side.

Runs ``suture-fem reproduce --no-pictures`` once per model (tied, sliding, frictionless, Coulomb at
friction coefficients 0.1, 0.3, 0.5), uncalibrated (``--calibrate none``) and, with ``--calibrated``,
under the one-parameter protocol (``materials.tissue_scale`` fitted to USUM 4.0 mm at 4 cones, 1 N). Prints
the seven paper USUM values against each model's, the 1-cone to 4-cone USUM ratio (the paper's 1.825),
and the converged stress and strain measures near a cone at 1 N, and writes JSON.

    .venv/bin/python benchmarks/reproduce_interfaces.py [--out benchmarks/out/reproduce_interfaces]
        [--calibrated] [--reuse] [--timeout 1800] [--vary thread|cone] [--models "frictionless,coulomb 0.1"]

``--vary cone`` sets ``effects.cone_interface`` instead, the thread tied. ``--models`` runs only those named.
The CPU reported is every child process's (reproduce and its ramps' processes), from ``getrusage``.

``--reuse`` reads an earlier run's folders instead of solving again. A model whose reproduce run
stops or times out is reported as such (its folder keeps what converged).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"tied": [], "sliding": [], "frictionless": []}
MODELS.update({f"coulomb {mu}": [f"effects.friction_coefficient={mu}"] for mu in (0.1, 0.3, 0.5)})


def run(model: str, calibrated: bool, out: Path, timeout: float, vary: str = "thread") -> dict:
    """One reproduce run (or its earlier output): exit code, CPU seconds and the comparison."""
    interface = model.split()[0]
    args = [sys.executable, "-P", "-m", "suture_fem.cli", "reproduce", "--no-pictures", "--out", str(out),
            "--set", f'effects.{vary}_interface="{interface}"']
    for kv in MODELS[model]:
        args += ["--set", kv]
    if not calibrated:
        args += ["--calibrate", "none"]
    row: dict = {"model": model, "calibrated": calibrated}
    if out.joinpath("comparison.json").is_file() and REUSE:
        row["exit"] = 0
    else:
        t0 = _children_cpu()
        try:
            proc = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=timeout)
            row["exit"] = proc.returncode
        except subprocess.TimeoutExpired:
            row["exit"] = None
        row["cpu_children_s"] = _children_cpu() - t0
    path = out / "comparison.json"
    row["comparison"] = json.loads(path.read_text()) if path.is_file() else None
    return row


def _children_cpu() -> float:
    """CPU seconds (user + system) of every finished child process so far (reproduce and its --jobs children)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def usum_table(rows: list[dict]) -> str:
    """The paper's USUM values against each model's, with the relative error, and the 1/4-cone ratio."""
    cases = []
    for r in rows:
        for c in (r["comparison"] or {}).get("rows", []):
            key = (c["cones"], c["force_n"], c["paper"])
            if c["quantity"] == "usum_mm" and key not in cases:
                cases.append(key)
    cases.sort()
    head = "| cones | force (N) | paper (mm) | " + " | ".join(r["model"] for r in rows) + " |"
    lines = [head, "| " + " | ".join(["---"] * (3 + len(rows))) + " |"]
    values = {r["model"]: {(c["cones"], c["force_n"]): c["ours"] for c in (r["comparison"] or {}).get("rows", [])
                           if c["quantity"] == "usum_mm"} for r in rows}
    for cones, force, paper in cases:
        cells = []
        for r in rows:
            v = values[r["model"]].get((cones, force))
            cells.append(f"{v:.3f} ({(v / paper - 1) * 100:+.1f} %)" if v is not None else "-")
        lines.append(f"| {cones} | {force:g} | {paper:g} | " + " | ".join(cells) + " |")
    ratio = []
    for r in rows:
        v = values[r["model"]]
        one, four = v.get((1, 1.0)), v.get((4, 1.0))
        ratio.append(f"{one / four:.3f}" if one and four else "-")
    lines.append("| 1 / 4 cones at 1 N | | 1.825 | " + " | ".join(ratio) + " |")
    return "\n".join(lines) + "\n"


def stress_table(rows: list[dict]) -> str:
    """The converged measures near a cone at 1 N (critical-distance average), per cone count."""
    lines = ["| measure | cones | paper | " + " | ".join(r["model"] for r in rows) + " |",
             "| " + " | ".join(["---"] * (3 + len(rows))) + " |"]
    for measure, scale, unit in (("seqv_cd_cone_pa", 1e-3, "kPa"), ("eptoeqv_cd_cone", 1.0, "")):
        for cones in ("1", "2", "3", "4"):
            paper, cells = None, []
            for r in rows:
                found = next((m for m in ((r["comparison"] or {}).get("stress") or {}).get("rows", [])
                              if m["measure"] == measure), None)
                if found is None:
                    cells.append("-")
                    continue
                paper = paper if paper is not None else found["paper"].get(cones)
                v = found["ours"].get(cones)
                cells.append(f"{v * scale:.4g}" if v is not None else "-")
            p = f"{paper * scale:.4g}" if paper is not None else "-"
            lines.append(f"| {measure} {unit} | {cones} | {p} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


REUSE = False


def main(argv: list[str] | None = None) -> int:
    """Run (or read) every model, print the tables, write the JSON."""
    global REUSE
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "reproduce_interfaces"))
    ap.add_argument("--calibrated", action="store_true", help="also under the one-parameter protocol")
    ap.add_argument("--reuse", action="store_true", help="read earlier runs' folders where they exist")
    ap.add_argument("--timeout", type=float, default=1800.0)
    ap.add_argument("--vary", choices=("thread", "cone"), default="thread")
    ap.add_argument("--models", default=",".join(MODELS),
                    help=f"comma-separated models to run (default all: {', '.join(MODELS)})")
    args = ap.parse_args(argv)
    models = [m.strip() for m in args.models.split(",")]
    unknown = [m for m in models if m not in MODELS]
    if unknown:
        ap.error(f"--models: unknown {unknown} (known: {', '.join(MODELS)})")
    REUSE = args.reuse
    out = Path(args.out)
    rows = []
    for calibrated in (False, True) if args.calibrated else (False,):
        for model in models:
            tag = ("calibrated_" if calibrated else "") + model.replace(" ", "_")
            rows.append(run(model, calibrated, out / tag, args.timeout, args.vary))
    for calibrated in (False, True):
        part = [r for r in rows if r["calibrated"] == calibrated]
        if part:
            print(f"\n### USUM, {'calibrated (materials.tissue_scale)' if calibrated else 'uncalibrated'}\n")
            print(usum_table(part))
            print(stress_table(part))
    for r in rows:
        print(f"{r['model']}{' (calibrated)' if r['calibrated'] else ''}: exit {r['exit']}, "
              f"CPU {r.get('cpu_children_s', float('nan')):.1f} s")
    out.mkdir(parents=True, exist_ok=True)
    slim = [{k: v for k, v in r.items() if k != "comparison"} | {"usum": usum_table([r])} for r in rows]
    (out / "reproduce_interfaces.json").write_text(json.dumps(slim, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
