"""The tests too long for the default suite (marker ``long``): run them, print a table, write JSON.

    .venv/bin/python benchmarks/long_tests.py [pytest args ...]      # benchmarks/out/long_tests.json

The default suite (``bash scripts/test.sh``) deselects them (pyproject.toml: ``-m "not long"``); each
costs from half a minute to several minutes of CPU (calibration fits over many noise draws, the
calibrated reproduction of every cone count, solves at the ends of a calibration's bounds).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> int:
    out = ROOT / "benchmarks" / "out"
    out.mkdir(parents=True, exist_ok=True)
    junit = out / "long_tests.xml"
    env = {**os.environ, "OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1",
           "OMPI_MCA_rmaps_base_oversubscribe": "1", "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1"),
           "PYTHONPATH": str(ROOT)}  # -P keeps the current folder off the path: the tests' package by name
    t0, cpu0 = time.perf_counter(), os.times()
    done = subprocess.run([sys.executable, "-P", "-m", "pytest", "-m", "long", "-q", "-rA", "-s",
                           f"--junitxml={junit}", *sys.argv[1:]], cwd=ROOT, env=env)
    cpu1 = os.times()
    rows = []
    for case in ET.parse(junit).getroot().iter("testcase"):
        outcome = "passed"
        for tag in ("failure", "error", "skipped"):
            if case.find(tag) is not None:
                outcome = {"failure": "failed", "error": "error", "skipped": "skipped/xfail"}[tag]
        rows.append({"test": f"{case.get('classname')}::{case.get('name')}", "wall_s": float(case.get("time", 0)),
                     "outcome": outcome})
    width = max((len(r["test"]) for r in rows), default=4)
    print(f"\n{'test':<{width}}  {'wall (s)':>9}  outcome")
    for r in rows:
        print(f"{r['test']:<{width}}  {r['wall_s']:9.1f}  {r['outcome']}")
    children_cpu = (cpu1.children_user + cpu1.children_system) - (cpu0.children_user + cpu0.children_system)
    record = {"exit_code": done.returncode, "wall_s": time.perf_counter() - t0, "cpu_s_children": children_cpu,
              "load_average": os.getloadavg(), "tests": rows}
    (out / "long_tests.json").write_text(json.dumps(record, indent=2) + "\n")
    print(f"wrote {out / 'long_tests.json'} (exit code {done.returncode})")
    return done.returncode


if __name__ == "__main__":
    sys.exit(main())
