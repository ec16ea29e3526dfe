"""The FElupe peer comparison: ours and FElupe on the same mesh, side by side, once they are shown to agree.

:func:`compare` (``benchmarks/speed.py --peer`` / ``--peer-only``) runs, each as a child process of
this one with its CPU from rusage: this script's ``--check``; ``suture-fem run paper`` at the degree
(USUM only, no pictures); the FElupe solve (``benchmarks/peer_felupe.py --child``); and ``suture-fem
mesh`` (our imports and meshing alone, for the CPU beyond them). It returns the rows and a table with
the CPU ratio, the Newton iterations, USUM of each and their difference; it asserts nothing.

``--check``: the same smooth displacement field set in both codes on the same mesh gives their strain
energies and residual vectors (with the pull at 4 N) node by node, and FElupe's triangles' shape-function
gradients against central differences (FElupe 11.3's ``QuadraticTriangle`` is off; the corrected one
of ``peer_felupe.py`` is not). See docs/peer.md.

    .venv/bin/python benchmarks/peer_compare.py --check [--degree 2] [--out X.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from peer_felupe import (  # noqa: E402  (beside this script; its children run with python -P)
    MM,
    corrected_quadratic_triangle,
    felupe_model,
    gmsh_mesh,
    scene,
    strain_energy,
)


def check_gradients() -> dict[str, float]:
    """Max |FElupe's shape-function gradient - central differences| for its triangles (P1, P2)."""
    import felupe as fem

    rng = np.random.default_rng(0)
    errors = {}
    elements = {"Triangle": fem.Triangle(), "QuadraticTriangle": fem.QuadraticTriangle(),
                "QuadraticTriangle corrected": corrected_quadratic_triangle()}
    for name, element in elements.items():
        worst = 0.0
        for _ in range(20):
            rs = rng.dirichlet(np.ones(3))[:2]
            h = 1e-6
            fd = np.stack([(element.function(rs + h * e) - element.function(rs - h * e)) / (2 * h)
                           for e in np.eye(2)], axis=1)
            worst = max(worst, float(np.max(np.abs(element.gradient(rs) - fd))))
        errors[name] = worst
    return errors


def test_field(rz: np.ndarray) -> np.ndarray:
    """A smooth admissible displacement (m) at points (r, z) in m: u_r = 0 on the axis, 0 on the outer surface."""
    r, z = rz[:, 0] / MM, rz[:, 1] / MM
    bump = np.exp(-(((z - 20.0) / 8.0) ** 2)) * (1 - r / 3.6)
    return np.stack([0.02 * r * bump * np.sin(z / 3.0), 0.3 * bump + 0.01 * np.cos(z / 5.0) * (3.6 - r)], axis=1) * MM


def check_energies(degree: int, force_n: float = 4.0) -> dict[str, float]:
    """Strain energy and residual of ours and FElupe's for the same displacement on the same mesh."""
    import dolfinx.fem
    import dolfinx.fem.petsc
    import felupe as fem
    from mpi4py import MPI
    from scipy.spatial import cKDTree

    from suture_fem.geometry.mesh import create_mesh
    from suture_fem.physics.problem import build_physics

    sc = scene(degree)
    physics = build_physics(create_mesh(MPI.COMM_SELF, sc.geometry, sc.mesh), sc)
    gm = gmsh_mesh(sc)
    model = felupe_model(sc, gm)
    xy = physics.V.tabulate_dof_coordinates()[:, :2]
    dist, node = cKDTree(model.points_rz_m).query(xy)
    u = test_field(model.points_rz_m)
    assert dist.max() < 1e-12 and len(np.unique(node)) == len(node) == len(u), "the same nodes"
    physics.u.x.array[:] = u[node].ravel()
    model.field[0].values[:] = u[:, ::-1]  # (u_z, u_r)
    ours = float(dolfinx.fem.assemble_scalar(physics.form("energy")))
    theirs = strain_energy(model)
    physics.set_force(force_n)
    model.load.update(force_n * model.unit_force)
    b = dolfinx.fem.petsc.assemble_vector(physics.form("residual")).getArray().reshape(-1, 2)
    r_ours = np.zeros_like(u)
    r_ours[node] = b
    # FElupe's residual as its Newton-Raphson assembles it (internal forces minus the point load)
    r_fel = fem.tools.fun([*model.solids, model.load], model.field).reshape(-1, 2)[:, ::-1]
    return {"energy_ours_j": ours, "energy_felupe_j": theirs, "energy_rel_diff": theirs / ours - 1.0,
            "residual_max_abs_diff_n": float(np.max(np.abs(r_ours - r_fel))),
            "residual_max_abs_n": float(np.max(np.abs(r_ours)))}


def ours_args(degree: int) -> list[str]:
    """Our side of the comparison: the same scene, USUM only (FElupe computes nothing else), no pictures."""
    return ["run", "paper", "--set", f"mesh.degree={degree}", "--set", 'output.quantities=["usum"]', "--no-pictures"]


def _rusage(cmd: list[str], env: dict[str, str], cwd: Path) -> dict[str, Any]:
    """Run ``cmd`` as a child process: its exit code, CPU seconds (user + system), wall seconds, peak MB."""
    import os
    import subprocess

    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, env=env, cwd=str(cwd), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    row = {"exit": os.waitstatus_to_exitcode(status), "cpu_s": usage.ru_utime + usage.ru_stime,
           "wall_s": time.perf_counter() - t0, "peak_mb": usage.ru_maxrss / 1024,
           "load": [load, os.getloadavg()[0]]}
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if row["exit"] != 0:
        row["error"] = err[-800:]
    return row


def compare(code: Path, tmp: Path, degree: int = 1) -> tuple[list[dict[str, Any]], str]:
    """Ours (``code``: a tree or worktree of suture_fem) and FElupe, each in its own child process, side by side.

    Returns the two rows and a text with the table, the CPU ratio, the USUM differences and the checks.
    """
    import os

    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1")
    py = [sys.executable, "-P"]
    check = tmp / "peer_check.json"
    here = Path(__file__).resolve().parent
    checked = _rusage([*py, str(here / "peer_compare.py"), "--check", "--degree", str(degree), "--out", str(check)],
                      env, code)
    ours = {"code": "suture_fem", **_rusage([*py, "-m", "suture_fem.cli", *ours_args(degree), "--out",
                                             str(tmp / "ours")], env, code)}
    ours.update(_ours_results(tmp / "ours" / "results.json"))
    fel = {"code": "FElupe", **_rusage([*py, str(here / "peer_felupe.py"), "--degree", str(degree), "--child",
                                        "--out", str(tmp / "fel.json")], env, code)}
    # our fixed cost, for the CPU beyond imports and meshing: the same imports and gmsh meshing, no solve
    meshing = _rusage([*py, "-m", "suture_fem.cli", "mesh", "paper", "--set", f"mesh.degree={degree}", "--out",
                       str(tmp / "mesh.msh")], env, code)
    ours["imports_meshing_cpu_s"] = meshing["cpu_s"] if meshing["exit"] == 0 else None
    if (tmp / "fel.json").is_file():
        fel.update(json.loads((tmp / "fel.json").read_text()))
    rows = [ours, fel]
    checks = json.loads(check.read_text()) if check.is_file() else {"error": checked.get("error")}
    return rows, _text(rows, checks, degree)


def _ours_results(path: Path) -> dict[str, Any]:
    if not path.is_file():
        return {}
    r = json.loads(path.read_text())
    rows = [{"force_n": a["force_n"], "usum_mm": a["usum_mm"], "strain_energy_j": a.get("strain_energy_j"),
             "residual_n": a.get("free_residual_norm_n")} for a in r.get("at_forces", [])]
    return {"newton_iterations": r.get("newton_iterations"), "solves": r.get("load_steps"),
            "cutbacks": r.get("cutbacks"), "at_forces": rows, "usum_mm": r.get("usum_mm"),
            "unknowns": r.get("unknowns"), "newton_wall_s": r.get("timings_s", {}).get("newton_total"),
            "linear_solver": r.get("linear_solver")}


def _text(rows: list[dict[str, Any]], checks: dict[str, Any], degree: int) -> str:
    head = ("| code | CPU (s) | wall (s) | peak (MB) | Newton its | load steps | USUM at 1 / 2 / 3 / 4 N (mm) "
            "| free residual at 4 N (N) | load |\n" + "| --- " * 9 + "|\n")
    body = ""
    for r in rows:
        at = r.get("at_forces", [])
        usum = " / ".join(f"{a['usum_mm']:.9f}" for a in at)
        res = f"{at[-1]['residual_n']:.1e}" if at and at[-1].get("residual_n") is not None else "-"
        body += (f"| {r['code']} | {r['cpu_s']:.2f} | {r['wall_s']:.1f} | {r['peak_mb']:.0f} "
                 f"| {r.get('newton_iterations')} | {r.get('solves')} | {usum} | {res} "
                 f"| {r['load'][0]:.1f} / {r['load'][1]:.1f} |\n")
    ours, fel = rows
    lines = [head + body]
    if ours["exit"] == 0 and fel["exit"] == 0:
        lines.append(f"CPU FElupe / suture_fem = {fel['cpu_s'] / ours['cpu_s']:.2f} (whole child processes)")
        phases = fel.get("cpu_phases_s", {})
        lines.append("FElupe CPU by phase (s): " + ", ".join(f"{k} {v:.2f}" for k, v in phases.items()))
        if ours.get("imports_meshing_cpu_s") and phases:
            mine = ours["cpu_s"] - ours["imports_meshing_cpu_s"]
            theirs = phases.get("setup", 0.0) + phases.get("solve", 0.0)
            lines.append(f"CPU beyond imports and meshing: suture_fem {mine:.2f} s (its total minus the CPU of "
                         f"`suture-fem mesh`, {ours['imports_meshing_cpu_s']:.2f} s), FElupe {theirs:.2f} s "
                         f"(setup + solve): FElupe / suture_fem = {theirs / mine:.2f}")
        diffs = [f"{a['force_n']:g} N: {b['usum_mm'] - a['usum_mm']:+.1e} mm ({b['usum_mm'] / a['usum_mm'] - 1:+.1e})"
                 for a, b in zip(ours.get("at_forces", []), fel.get("at_forces", []))]
        lines.append("USUM FElupe - suture_fem: " + "; ".join(diffs))
    else:
        lines += [f"{r['code']} failed (exit {r['exit']}): {r.get('error', '')}" for r in rows if r["exit"] != 0]
    if "energy_rel_diff" in checks:
        lines.append(f"Same displacement field, same mesh: strain energy FElupe / suture_fem - 1 = "
                     f"{checks['energy_rel_diff']:.1e}; residual max |diff| {checks['residual_max_abs_diff_n']:.1e} N "
                     f"of max |r| {checks['residual_max_abs_n']:.1e} N")
        g = checks["gradient_fd_error"]
        lines.append("FElupe shape-function gradients vs central differences, max |diff|: "
                     + ", ".join(f"{k} {v:.1e}" for k, v in g.items())
                     + (" (FElupe's QuadraticTriangle is miscoded: P2 runs with the corrected element)" if degree == 2
                        else " (FElupe's QuadraticTriangle is miscoded: this comparison is at P1)"))
    else:
        lines.append(f"checks failed: {checks}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="energy, residual and element-gradient checks")
    ap.add_argument("--degree", type=int, choices=(1, 2), default=1, help="P1, or P2 (corrected element)")
    ap.add_argument("--out", default=None, help="JSON output path")
    args = ap.parse_args()
    if not args.check:
        ap.error("give --check (the comparison itself: benchmarks/speed.py --peer-only)")
    report = {"gradient_fd_error": check_gradients(), **check_energies(args.degree)}
    print(json.dumps(report, indent=1))
    if args.out:
        Path(args.out).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
