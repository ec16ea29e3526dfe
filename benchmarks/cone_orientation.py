"""Benchmark: what the cones hold pulled apex first (the paper) and base first, once the thread slides.

For each cone count, cone kind ("full" or "hollow") and orientation, the pulled end is moved 4 mm
(`loading.control = "displacement"`, reports at 1, 2 and 3 mm, P1) with the thread and cones tied (the
paper's model) and with nothing tied: a sliding thread with frictionless cones, and with Coulomb cones
(mu 0.3). Each case is one `suture-fem run` in a fresh process (a stopped case is a row too). Prints a
table (the force at 1-4 mm, each cone's share, the tissue's next layer on the cones and the cones' corners inside
the tissue at the last state, Newton iterations, cutbacks, CPU of the child process) and writes JSON. ``--corners
held`` holds the unilateral cones' corners out of the tissue (``effects.cone_corners``; default: measured).

    .venv/bin/python benchmarks/cone_orientation.py [--out benchmarks/out/cone_orientation] [--cones 1,4]
        [--kinds full,hollow] [--orientations apex_to_pull,base_to_pull] [--interfaces tied,frictionless,coulomb]
        [--corners measured|held]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from speed import ROOT, run  # noqa: E402

from suture_fem.support.io import write_json  # noqa: E402

MOVE = ['loading.control="displacement"', "loading.displacement_mm=4", "loading.report_displacements_mm=[1,2,3]",
        "mesh.degree=1"]
INTERFACES = {
    "tied": [],
    "frictionless": ['effects.thread_interface="sliding"', 'effects.cone_interface="frictionless"'],
    "coulomb": ['effects.thread_interface="sliding"', 'effects.cone_interface="coulomb"',
                "effects.friction_coefficient=0.3"],
}
ORIENTATIONS = ("apex_to_pull", "base_to_pull")


def case(cones: int, kind: str, orientation: str, interface: str, out: Path, corners: str = "measured") -> dict:
    """One run (benchmarks/speed.py's ``run``: its own process, its CPU); its forces, shares and cost."""
    folder = out / f"{kind}_{cones}_{orientation}_{interface}"
    held = [f'effects.cone_corners="{corners}"'] if interface != "tied" else []  # "measured": the default
    values = [*MOVE, f"geometry.cones={cones}", f'geometry.cone_kind="{kind}"',
              f'geometry.cone_orientation="{orientation}"', *INTERFACES[interface], *held]
    args = ["run", "paper", "--no-pictures"]
    for v in values:
        args += ["--set", v]
    done = run(ROOT, args, folder)
    row = {"cones": cones, "kind": kind, "orientation": orientation, "interface": interface, "exit": done["exit"],
           "cpu_s": round(done["cpu_s"], 1)}
    path = folder / "results.json"
    if not path.exists():
        return {**row, "error": done.get("error", "")}
    r = json.loads(path.read_text())
    row.update(status=r["status"], reached_mm=r.get("thread_end_displacement_mm", 0.0),
               force_n=r.get("force_reached_n", 0.0),
               newton_iterations=r.get("newton_iterations", "-"), cutbacks=r.get("cutbacks", "-"),
               forces_n={f"{a['thread_end_displacement_mm']:.3g}": a["force_n"] for a in r["at_forces"]},
               shares_n=r.get("load_share_n"))
    contact = r.get("interface", {}).get("cone_contact", {})
    if "next_layer_pressed_nodes" in contact:  # the tissue's next layer against the cones at the last state
        row.update(next_layer_pressed=contact["next_layer_pressed_nodes"],
                   next_layer_depth_um=round(1e3 * contact["next_layer_penetration_max_mm"], 3))
    if "corners_inside_tissue" in contact:  # the cones' corners past the tissue's facets at the last state
        row.update(corners_inside=contact["corners_inside_tissue"],
                   corner_depth_um=round(1e3 * contact["corner_penetration_max_mm"], 3))
    if r["status"] != "converged":
        row["stop"] = r.get("diagnosis") or r["status"]
    return row


def table(rows: list[dict]) -> str:
    """The rows as a markdown table."""
    lines = ["| cones | kind | orientation | thread / cones | force at 1 / 2 / 3 / 4 mm (N) | outcome | cones' shares "
             "at the last state (N) | next layer pressed, deepest (um) | corners inside, deepest (um) | Newton its | "
             "cutbacks | CPU s |",
             "| --- " * 12 + "|"]
    for r in rows:
        if "status" not in r:
            lines.append(f"| {r['cones']} | {r['kind']} | {r['orientation']} | {r['interface']} | - | no results "
                         f"(exit {r['exit']}) | - | - | - | - | - | {r['cpu_s']} |")
            continue
        forces = " / ".join(f"{r['forces_n'][d]:.4f}" if d in r["forces_n"] else "-" for d in ("1", "2", "3", "4"))
        outcome = "4 mm" if r["status"] == "converged" else f"stopped at {r['reached_mm']:.3g} mm, {r['force_n']:.3g} N"
        shares = r["shares_n"] or {}
        cones = " / ".join(f"{v:.3f}" for k, v in shares.items() if k.startswith("cone"))
        thread = "sliding" if r["interface"] != "tied" else "tied"
        layer = f"{r['next_layer_pressed']}, {r['next_layer_depth_um']:.3g}" if "next_layer_pressed" in r else "-"
        corners = f"{r['corners_inside']}, {r['corner_depth_um']:.3g}" if "corners_inside" in r else "-"
        lines.append(f"| {r['cones']} | {r['kind']} | {r['orientation']} | {thread} / {r['interface']} | {forces} | "
                     f"{outcome} | {cones} | {layer} | {corners} | {r['newton_iterations']} | {r['cutbacks']} | "
                     f"{r['cpu_s']} |")
    return "\n".join(lines)


def main() -> None:
    """Run every case, print the table, write the JSON."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="benchmarks/out/cone_orientation")
    p.add_argument("--cones", default="1,4")
    p.add_argument("--kinds", default="full,hollow")
    p.add_argument("--interfaces", default="tied,frictionless,coulomb")
    p.add_argument("--orientations", default=",".join(ORIENTATIONS))
    p.add_argument("--corners", default="measured", choices=("measured", "held"))
    args = p.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    for c in args.cones.split(","):
        for k in args.kinds.split(","):
            for o in args.orientations.split(","):
                for i in args.interfaces.split(","):
                    rows.append(case(int(c), k, o, i, out, args.corners))
                    write_json(out / "cone_orientation.json", rows)  # the rows so far: a later crash keeps them
    print(table(rows))
    print(f"wrote {out / 'cone_orientation.json'}")


if __name__ == "__main__":
    main()
