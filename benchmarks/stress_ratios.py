"""How the paper's 2-to-4-cone stress and strain ratios depend on the fillet radius and the critical distance.

    .venv/bin/python benchmarks/stress_ratios.py [--set KEY=VALUE ...] [--out FILE.json]

Solves the paper_reproduction scene with 2 and 4 cones to 1 N for each fillet radius, evaluates the
tissue's critical-distance averages (near a cone and tissue-wide) for each distance on the same
states, prints a table of the 4-cone / 2-cone ratios (the paper: SEQV 0.36, EPTOEQV 0.79, Table 2)
and writes it as JSON.
"""

from __future__ import annotations

import argparse
import json

from mpi4py import MPI

from suture_fem.pipeline import load_scene
from suture_fem.studies.paper import SCENE
from suture_fem.studies.reproduce.stress import paper_table2, ratio_sensitivity

FILLETS_MM = (0.0, 0.02, 0.04)  # 0: sharp rims (the default; no fillet peak)
DISTANCES_MM = (0.05, 0.1, 0.2)


def main() -> None:
    """Print the table and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", default="stress_ratios.json")
    args = parser.parse_args()
    scene = load_scene(SCENE, args.set)
    rows = ratio_sensitivity(scene, MPI.COMM_WORLD, FILLETS_MM, DISTANCES_MM)
    table = paper_table2()
    paper = {k: table[4][k] / table[2][k] for k in ("seqv", "eptoeqv")}
    if MPI.COMM_WORLD.rank == 0:
        print(f"paper (Table 2, 1 N): SEQV 4/2 cones {paper['seqv']:.3f}, EPTOEQV {paper['eptoeqv']:.3f}")
        print("| fillet (mm) | critical distance (mm) | SEQV cd near a cone 4/2 | EPTOEQV cd near a cone 4/2 "
              "| SEQV cd tissue-wide 4/2 | EPTOEQV cd tissue-wide 4/2 | SEQV fillet 4/2 | EPTOEQV fillet 4/2 |")
        print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for r in rows:
            cells = [r[k] for k in ("seqv_cd_cone_pa_ratio", "eptoeqv_cd_cone_ratio", "seqv_cd_pa_ratio",
                                    "eptoeqv_cd_ratio", "seqv_fillet_pa_ratio", "eptoeqv_fillet_ratio")]
            print(f"| {r['fillet_mm']:g} | {r['critical_distance_mm']:g} | "
                  + " | ".join("-" if c is None else f"{c:.3f}" for c in cells) + " |")
        with open(args.out, "w") as f:
            json.dump({"scene_sets": args.set, "paper_ratio": paper, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
