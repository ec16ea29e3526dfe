"""Benchmark: the 3-D slab (geometry.tissue_shape = "slab") against the 3-D cylinder, its lateral width, its dimples.

Each run is ``suture-fem run paper --set ...`` in its own process under GNU time (CPU seconds of all ranks, peak
resident memory), one at a time, P1 tetrahedra on the [mesh] sizes times ``--factor`` (default 4, the coarsest
rung of benchmarks/three_d.py), pulled to 4 N with reports at 1, 2 and 3 N, ``--cones`` 1 and 4. Parts:

* ``width``: the slab at two lateral half widths (geometry.slab_half_width_mm 20, the default, and 40 mm;
  ``--widths``), 1 and 4 cones: how much USUM and the dimple move when the fixed lateral faces move twice as far.
* ``compare``: slab (thread 3.6 mm deep: the cylinder's distance from the thread to the skin) against the 3-D
  cylinder on the same sizes, 1 and 4 cones, 1 and 4 N: USUM, the thread end, the energy, the tissue's SEQV and
  EPTOEQV (peak and outside the rims).
* ``dimple``: the dimple depth over each cone at 1-4 N, 1 and 4 cones, thread depths 3.6 and 2.0 mm, and its relief
  (the depth under a straightedge across the cone: results.json's ``dimple_relief_mm``); the block's
  end margins from ``--dimple-margins`` (the scene's 3 mm if not given: that measures the block's tilt).
* ``margins``: the block's free end faces moved from 3 mm (geometry.margin_far_mm / margin_pull_mm, the
  cylinder's default) to farther from the cones (``--margins``, each end alone and both): the dimple over each
  cone, USUM and the skin's extremes (the tilt), 1 and 4 N.

    .venv/bin/python benchmarks/slab.py [--parts compare dimple width] [--factor 4] [--cones 1 4]
        [--margins 3 10 20] [--dimple-margins 10 10] [--out benchmarks/out/slab]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from three_d import BASE_3D, QUANTITIES, TISSUE, at, run, sized, table  # noqa: E402

from suture_fem.support.io import write_json  # noqa: E402

FORCES = (1.0, 2.0, 3.0, 4.0)
LOAD = ["loading.force_n=4.0", "loading.report_forces_n=[1.0,2.0,3.0]"]
SLAB = [*BASE_3D[:-1], 'output.quantities=["usum","seqv","eptoeqv","dimple"]', 'geometry.tissue_shape="slab"']
DEPTHS = (3.6, 2.0)
#: The lateral half widths (mm): the default, then twice it (``--widths`` changes them).
WIDTHS = [20.0, 40.0]
#: The block's end margins (mm, far and pulled end alike): the default first (``--margins`` changes them).
MARGINS = [3.0, 10.0]
#: The block's end margins (far, pulled end; mm) of the dimple part; empty: the scene's (3 mm each). A dimple is
#: measured with both ends at least 10 mm from the cones (docs/three-d.md, "The block's ends").
DIMPLE_MARGINS: list[tuple[float, float]] = []
#: Runs already made in this process, by label (the compare, width and dimple parts share some).
DONE: dict[str, dict] = {}


def solve(label: str, overrides: list[str], tmp: Path) -> dict:
    """One run (or the same label's earlier one)."""
    if label not in DONE:
        DONE[label] = run(label, overrides, tmp)
    return DONE[label]


def slab(cones: int, depth: float, width: float, factor: float, tmp: Path, margins: tuple | None = None) -> dict:
    """The slab with ``cones`` cones, the thread ``depth`` mm under the skin, lateral faces ``width`` mm away.

    ``margins`` (far, pulled end; mm) moves the block's free end faces; None keeps the scene's (3 mm each).
    """
    ends = [] if margins is None else [f"geometry.margin_far_mm={margins[0]}", f"geometry.margin_pull_mm={margins[1]}"]
    tag = "" if margins is None else f" m{margins[0]:g}-{margins[1]:g}"
    return solve(f"slab {cones} cones d{depth:g} w{width:g} x{factor:g}{tag}",
                 [*SLAB, *LOAD, f"geometry.cones={cones}", f"geometry.thread_depth_mm={depth}",
                  f"geometry.slab_half_width_mm={width}", *ends, *sized(factor)], tmp)


def cylinder(cones: int, factor: float, tmp: Path) -> dict:
    """The 3-D cylinder with ``cones`` cones."""
    return solve(f"cylinder {cones} cones x{factor:g}", [*BASE_3D, *LOAD, f"geometry.cones={cones}", *sized(factor)],
                 tmp)


def cost(res: dict) -> dict:
    """What a run took."""
    return {"dofs": res.get("dofs"), "cells": res.get("cells"), "cpu_s": res["process_cpu_s"],
            "peak_memory_mb": res["peak_memory_mb"], "newton_iterations": res.get("newton_iterations"),
            "status": res.get("status"), "force_reached_n": res.get("force_reached_n")}


def state(res: dict, force: float) -> dict:
    """The compared quantities at one force (None where the run did not reach it)."""
    s = at(res, force)
    tissue = s.get("regions", {}).get("tissue", {})
    return {**{q: s.get(q) for q in QUANTITIES}, **{f"tissue_{q}": tissue.get(q) for q in TISSUE},
            "dimple_depth_mm": s.get("dimple_depth_mm"), "skin_inward_mm": s.get("skin_inward_mm"),
            "skin_outward_mm": s.get("skin_outward_mm")}


def width(factor: float, cones_list: list[int], tmp: Path) -> list[dict]:
    """USUM and the dimples at two lateral half widths."""
    rows = []
    for cones in cones_list:
        base = slab(cones, DEPTHS[0], WIDTHS[0], factor, tmp)
        wide = slab(cones, DEPTHS[0], WIDTHS[1], factor, tmp)
        for force in (1.0, 4.0):
            a, b = state(base, force), state(wide, force)
            change = (b["usum_mm"] / a["usum_mm"] - 1.0) if a["usum_mm"] and b["usum_mm"] else None
            rows.append({"cones": cones, "force_n": force, f"usum_mm_w{WIDTHS[0]:g}": a["usum_mm"],
                         f"usum_mm_w{WIDTHS[1]:g}": b["usum_mm"], "usum_change": change,
                         f"dimples_w{WIDTHS[0]:g}": a["dimple_depth_mm"],
                         f"dimples_w{WIDTHS[1]:g}": b["dimple_depth_mm"],
                         f"dofs_w{WIDTHS[0]:g}": base.get("dofs"), f"dofs_w{WIDTHS[1]:g}": wide.get("dofs")})
    return rows


def compare(factor: float, cones_list: list[int], tmp: Path) -> list[dict]:
    """Slab against cylinder, 1 and 4 cones, 1 and 4 N."""
    rows = []
    for cones in cones_list:
        for name, res in (("cylinder", cylinder(cones, factor, tmp)),
                          ("slab", slab(cones, DEPTHS[0], WIDTHS[0], factor, tmp))):
            for force in (1.0, 4.0):
                rows.append({"cones": cones, "model": name, "force_n": force, **cost(res), **state(res, force)})
    return rows


def dimple(factor: float, cones_list: list[int], tmp: Path) -> list[dict]:
    """The dimple depth over each cone at 1-4 N, two thread depths (the block's ends at ``DIMPLE_MARGINS``)."""
    rows = []
    for cones in cones_list:
        for depth in DEPTHS:
            res = slab(cones, depth, WIDTHS[0], factor, tmp, DIMPLE_MARGINS[0] if DIMPLE_MARGINS else None)
            for force in FORCES:
                s = state(res, force)
                rows.append({"cones": cones, "thread_depth_mm": depth, "force_n": force, "dofs": res.get("dofs"),
                             "cpu_s": res["process_cpu_s"], "peak_memory_mb": res["peak_memory_mb"],
                             "dimple_depth_mm": [round(d, 4) for d in s["dimple_depth_mm"] or []],
                             "dimple_relief_mm": [None if d is None else round(d, 4)
                                                  for d in at(res, force).get("dimple_relief_mm") or []],
                             "dimple_relief_at_y_mm": at(res, force).get("dimple_relief_at_y_mm"),
                             "skin_inward_mm": s["skin_inward_mm"], "skin_outward_mm": s["skin_outward_mm"],
                             "usum_mm": s["usum_mm"], "skin_inward_at_mm": at(res, force).get("skin_inward_at_mm"),
                             "dimple_depth_at_mm": at(res, force).get("dimple_depth_at_mm"),
                             "skin_profile_mm": at(res, force).get("skin_profile_mm")})
    return rows


def margins(factor: float, cones_list: list[int], tmp: Path) -> list[dict]:
    """The dimple over each cone, USUM and the skin's extremes as the block's free ends move away from the cones."""
    base, *far = MARGINS
    cases = [(base, base)] + [c for m in far for c in ((m, base), (base, m), (m, m))]
    rows = []
    for cones in cones_list:
        for far_mm, pull_mm in cases:
            res = slab(cones, DEPTHS[0], WIDTHS[0], factor, tmp, (far_mm, pull_mm))
            for force in (1.0, 4.0):
                s = state(res, force)
                rows.append({"cones": cones, "margin_far_mm": far_mm, "margin_pull_mm": pull_mm, "force_n": force,
                             "dofs": res.get("dofs"), "cpu_s": res["process_cpu_s"],
                             "peak_memory_mb": res["peak_memory_mb"], "usum_mm": s["usum_mm"],
                             "dimple_depth_mm": [round(d, 4) for d in s["dimple_depth_mm"] or []],
                             "dimple_depth_at_mm": at(res, force).get("dimple_depth_at_mm"),
                             "skin_inward_mm": s["skin_inward_mm"], "skin_outward_mm": s["skin_outward_mm"],
                             "skin_inward_at_mm": at(res, force).get("skin_inward_at_mm"),
                             "skin_outward_at_mm": at(res, force).get("skin_outward_at_mm"),
                             "skin_profile_mm": at(res, force).get("skin_profile_mm")})
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--parts", nargs="+", default=["compare", "dimple", "width"])
    parser.add_argument("--factor", type=float, default=4.0)
    parser.add_argument("--cones", type=int, nargs="+", default=[1, 4])
    parser.add_argument("--tag", default="", help="appended to the JSON files' names")
    parser.add_argument("--widths", type=float, nargs=2, default=WIDTHS)
    parser.add_argument("--margins", type=float, nargs="+", default=MARGINS)
    parser.add_argument("--dimple-margins", type=float, nargs=2, metavar=("FAR", "PULL"),
                        help="the dimple part's end margins (mm); default: the scene's")
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "out" / "slab"))
    args = parser.parse_args()
    WIDTHS[:] = args.widths
    MARGINS[:] = args.margins
    DIMPLE_MARGINS[:] = [tuple(args.dimple_margins)] if args.dimple_margins else []
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    parts = {"width": width, "compare": compare, "dimple": dimple, "margins": margins}
    columns = {
        "width": ["cones", "force_n", *[f"usum_mm_w{w:g}" for w in WIDTHS], "usum_change",
                  *[f"dimples_w{w:g}" for w in WIDTHS], *[f"dofs_w{w:g}" for w in WIDTHS]],
        "compare": ["cones", "model", "force_n", "dofs", "cpu_s", "peak_memory_mb", "status", "force_reached_n",
                    *QUANTITIES, *[f"tissue_{q}" for q in TISSUE]],
        "dimple": ["cones", "thread_depth_mm", "force_n", "dofs", "cpu_s", "peak_memory_mb", "dimple_depth_mm",
                   "dimple_relief_mm", "skin_inward_mm", "skin_outward_mm", "usum_mm"],
        "margins": ["cones", "margin_far_mm", "margin_pull_mm", "force_n", "dofs", "cpu_s", "peak_memory_mb",
                    "usum_mm", "dimple_depth_mm", "skin_inward_mm", "skin_outward_mm"],
    }
    columns["width"] = ["cones", "force_n", *[f"usum_mm_w{w:g}" for w in WIDTHS], "usum_change",
                        *[f"dimples_w{w:g}" for w in WIDTHS], *[f"dofs_w{w:g}" for w in WIDTHS]]
    with tempfile.TemporaryDirectory(prefix="slab_") as tmp:
        for name in args.parts:
            print(f"{name}:", flush=True)
            rows = parts[name](args.factor, args.cones, Path(tmp))
            write_json(out / f"{name}{args.tag}.json", {"part": name, "factor": args.factor, "rows": rows,
                                              "runs": {k: {**cost(v), "label": k} for k, v in DONE.items()}})
            print(table(rows, columns[name]), flush=True)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
