"""Benchmark: the verification numbers behind tests/verification, as tables.

1. Manufactured solutions: weighted L2 / H1 errors and observed rates for Yeoh (the paper's c10, c20
   with 1/d = 1 kPa, and with the paper's 1/d = 50 kPa, where K0/mu = 125), Gent and St Venant-Kirchhoff,
   degrees 1 and 2, on meshes h = L/8 ... L/128 (degree 1) and L/8 ... L/64 (degree 2).
2. Telescopic shear of the layered Yeoh tube and of the Gent tube: the FE profile against the exact
   incompressible one as 1/d grows (1x ... 1000x the paper's), and the shear-strain error under
   refinement.

    .venv/bin/python benchmarks/verification.py [--out benchmarks/out/verification.json]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mpi4py import MPI  # noqa: E402

from suture_fem.physics.materials import Gent, StVenantKirchhoff, Yeoh  # noqa: E402
from suture_fem.studies.verification.manufactured import manufactured_solve, observed_rates  # noqa: E402
from suture_fem.studies.verification.tube import tube_solve  # noqa: E402
from suture_fem.support.io import write_json  # noqa: E402
from tests.verification.test_manufactured import L, exact  # noqa: E402
from tests.verification.test_tube_shear import HEIGHT, case  # noqa: E402

MATERIALS = {
    "yeoh 1/d = 1 kPa": (Yeoh((400.0, 1400.0), (1e3, 1e3)), 1),
    "yeoh paper (K0/mu = 125)": (Yeoh((400.0, 1400.0), (50e3, 50e3)), 1),
    "gent paper": (Gent(4000.0, 1.2, 50e3), 3),
    "svk paper": (StVenantKirchhoff(1.5e9, 0.4), 4),
}
MESHES = {1: (8, 16, 32, 64, 128), 2: (8, 16, 32, 64)}


def manufactured() -> list[dict]:
    rows = []
    print("manufactured solutions: rates of consecutive meshes (L2 | H1)")
    for name, (material, tag) in MATERIALS.items():
        for degree, meshes in MESHES.items():
            runs = [manufactured_solve(MPI.COMM_WORLD, material, tag, exact, degree, n, L) for n in meshes]
            h = [r.h for r in runs]
            l2 = observed_rates(h, [r.l2 for r in runs])
            h1 = observed_rates(h, [r.h1 for r in runs])
            print(f"  {name:26s} P{degree}: " + " ".join(f"{a:5.2f}" for a in l2) + " | "
                  + " ".join(f"{b:5.2f}" for b in h1))
            rows.append({"material": name, "degree": degree, "n": list(meshes), "l2": [r.l2 for r in runs],
                         "h1": [r.h1 for r in runs], "l2_rates": l2, "h1_rates": h1})
    return rows


def tube() -> list[dict]:
    rows = []
    print("\ntube shear: max |u_z - w| / w(a) and max |u_r| / w(a) at 1/d x scale (P2, coarsest mesh); "
          "shear-strain error and its rate under refinement at 1000x")
    for name in ("layered_yeoh", "gent"):
        for scale in (1.0, 10.0, 100.0, 1000.0):
            exact_tube, tags, cells, tau = case(name, scale)
            res = tube_solve(MPI.COMM_WORLD, exact_tube, tags, 2, cells, 2, HEIGHT)
            row = {"tube": name, "inv_d_scale": scale, "axial_error": res.axial_error(),
                   "radial_displacement": res.radial_displacement(), "tau_core_pa": tau,
                   "core_displacement_mm": res.core_displacement * 1e3}
            rows.append(row)
            print(f"  {name:13s} x{scale:<6g} axial {row['axial_error']:.3e}  radial {row['radial_displacement']:.3e}  "
                  f"(w(a) = {row['core_displacement_mm']:.4f} mm)")
        exact_tube, tags, cells, _ = case(name, 1000.0)
        errs = [tube_solve(MPI.COMM_WORLD, exact_tube, tags, 2, [c * m for c in cells], 2 * m, HEIGHT).gradient_error
                for m in (1, 2, 4)]
        rates = [math.log2(a / b) for a, b in zip(errs, errs[1:])]
        print(f"  {name:13s} gradient errors {', '.join(f'{e:.3e}' for e in errs)}; rates {rates}")
        rows.append({"tube": name, "gradient_errors": errs, "gradient_rates": rates})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "benchmarks/out/verification.json"))
    args = ap.parse_args()
    record = {"manufactured": manufactured(), "tube": tube()}
    write_json(args.out, record)
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
