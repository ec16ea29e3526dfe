"""Benchmark: the hard-case matrix (suture_fem/studies/hardcases.py), each case in its own process.

Prints the table and writes JSON + Markdown: case, converged or stopped, cause, load reached,
Newton iterations, cutbacks, rejected trial states, USUM, unknowns, wall time; then case 1's USUM
against the bulk modulus for the plain and the mixed formulation. Fine-mesh and degree-2 cases are
slow (the whole matrix takes tens of minutes on 2 cores).

    .venv/bin/python benchmarks/hardcases.py [--only "K x1000" ...] [--timeout 3600] [--out benchmarks/out/hardcases]
        [--set mesh.degree=2 --out benchmarks/out/hardcases_p2]   (a key for every case, after the case's own)

With --only, the rows of the other cases are kept from the existing JSON, so the table stays whole.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from suture_fem.studies.hardcases import locking_table, markdown, matrix, run_case  # noqa: E402
from suture_fem.support.io import write_json, write_text  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="*", default=None, help="run the cases whose name starts with one of these")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds before a case counts as a hang")
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/hardcases"), help="output path without suffix")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene key for every case, after the case's own (e.g. mesh.degree=2; use another --out)")
    args = ap.parse_args()
    cases = [c for c in matrix() if args.only is None or any(c.name.startswith(p) for p in args.only)]
    out = Path(args.out)
    path = out.with_suffix(".json")
    # rows of cases not rerun now are kept from an earlier run, in matrix order
    kept = {r["case"]: r for r in json.loads(path.read_text())["rows"]} if path.is_file() else {}
    order = {c.name: i for i, c in enumerate(matrix())}

    def in_order() -> list[dict]:
        return sorted(kept.values(), key=lambda r: order.get(r["case"], len(order)))

    with tempfile.TemporaryDirectory() as tmp:
        for i, case in enumerate(cases):
            row = run_case(case.name, (*case.overrides, *args.set), Path(tmp) / f"case{i}", timeout_s=args.timeout)
            row.update(group=case.group, note=case.note)
            kept[case.name] = row
            print(f"[{i + 1}/{len(cases)}] {case.name}: {row['outcome']} {row.get('cause') or ''} "
                  f"{row.get('load_reached_n')} N, {row.get('wall_time_s') or 0:.1f} s", flush=True)
            write_json(path, {"rows": in_order()})  # keep what is done if interrupted
    rows = in_order()
    text = ("## Hard-case matrix\n\n" + markdown(rows)
            + "\n## Case 1: USUM, EPTOEQV and tissue SEQV at 4 N against the bulk modulus\n\n" + locking_table(rows))
    write_text(out.with_suffix(".md"), text)
    print(text)
    failed = [r["case"] for r in rows if r["outcome"] == "FAILED"]
    if failed:
        print("FAILED (neither converged nor stopped with a diagnosis):", ", ".join(failed))
        raise SystemExit(1)


if __name__ == "__main__":
    main()
