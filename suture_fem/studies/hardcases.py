"""The hard-case matrix: each case a scene, each run classified (converged or stopped with a diagnosis).

Every case is the built-in ``paper`` scene (4 hollow cones, 4 N, degree 2, refinement 0) with a few
``--set`` overrides. A run must end one of two ways:

* ``converged``: exit code 0, status "converged", USUM / SEQV / EPTOEQV finite, and the reaction of
  the fixed surface balancing the applied force (``force_balance_rel`` below BALANCE_TOL);
* ``stopped``: exit code 3 with a diagnosis naming a known cause, every converged step kept in
  results.json (status "stopped", the outputs of the last converged load finite).

Anything else (another exit code, a missing or non-finite output, an unbalanced reaction, a hang past
the time limit) is ``FAILED`` — the third way the issue forbids. ``benchmarks/hardcases.py`` runs the
whole matrix and writes JSON + Markdown; tests/stability runs a fast subset.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from suture_fem.geometry.regions import WHOLE_TISSUE
from suture_fem.support.errors import StopCause

#: Causes a stopped run may name (results.json's ``diagnosis.cause``, a plain string equal to its member).
CAUSES = tuple(StopCause)
#: Relative mismatch |reaction + F| / F a converged run may leave: Newton stops at |R| <= 1e-10 N
#: (solver.atol) or at the residual's round-off floor (below 1e-9 N on the paper scene) on forces of order
#: 1 N, so 1e-6 leaves three orders of margin and still catches a wrong sum.
BALANCE_TOL = 1e-6
VOLUMETRIC = ("hypodermis.inv_d1", "hypodermis.inv_d2", "dermis.inv_d1", "dermis.inv_d2", "epidermis.inv_d")
PAPER_INV_D = 50.0e3  # paper Table 3, every tissue layer


@dataclass(frozen=True)
class Case:
    """One scene of the matrix: ``group`` is the issue's case number (1-7)."""

    name: str
    group: int
    overrides: tuple[str, ...]
    note: str


def bulk(factor: float) -> tuple[str, ...]:
    """Every tissue volumetric coefficient (1/d) times factor: K0 = 2/d1 from 100 kPa to 100 MPa."""
    return tuple(f"materials.{k}={PAPER_INV_D * factor:g}" for k in VOLUMETRIC)


def matrix() -> list[Case]:
    """The full matrix (34 runs; "K x1 P2 displacement" is the paper scene itself)."""
    cases: list[Case] = []
    for factor in (1, 10, 100, 1000):
        for degree, formulation in ((1, "displacement"), (2, "displacement"), (2, "mixed")):
            cases.append(Case(
                f"K x{factor} P{degree} {formulation}", 1,
                (*bulk(factor), f"mesh.degree={degree}", f"effects.incompressibility={formulation}"),
                f"1/d of every layer x{factor} (nu_hypodermis = {poisson(factor):.6f})",
            ))
    for young in (15e6, 150e9):
        cases.append(Case(f"suture E = {young:g} Pa", 2, (f"materials.suture.young={young:g}",),
                          f"suture {young / 1.5e9:g} x the paper's 1.5 GPa"))
    for force in (8.0, 12.0):
        for cones in (1, 4):
            for degree in (1, 2):
                cases.append(Case(f"{force:g} N, {cones} cone{'s' * (cones > 1)}, P{degree}", 3,
                                  (f"loading.force_n={force:g}", f"geometry.cones={cones}", f"mesh.degree={degree}",
                                   "loading.report_forces_n=[1.0, 2.0, 4.0]"), "large force"))
    cases.append(Case("Gent jm = 0.05", 4, ("materials.epidermis.jm=0.05",),
                      "epidermis Jm lowered from 1.2 so the limit is reached inside the 4 N ramp"))
    # Case 5 at the default degree 2 is 667,550 dofs: its first load step had not converged after 32 min
    # on 2 shared cores, so the matrix runs the same element sizes at degree 1 and degree 2 one step finer.
    cases.append(Case("refinement 2, P1", 5, ("mesh.refinement=2", "mesh.degree=1"),
                      "every element size / 4 (167,742 dofs)"))
    cases.append(Case("refinement 1, P2", 5, ("mesh.refinement=1",), "every element size / 2 (174,762 dofs)"))
    cases.append(Case("8 hollow cones", 6, ("geometry.cones=8", "geometry.cone_kind=\"hollow\""), "many cones"))
    return cases + contact_cases()


#: Contact cases: P1 (the degree that carries a unilateral thread), the pulled end moved (a Coulomb thread
#: under force control crawls: docs/contact.md).
MOVED = ("mesh.degree=1", "loading.control=\"displacement\"")


def contact_cases() -> list[Case]:
    """Group 7: the thread in its own track, then the cones' surfaces (the thread tied), then nothing tied."""
    thread = _interface_cases("contact", "thread")
    thread.insert(5, Case("contact: frictionless, 12 mm", 7, (*MOVED, "effects.thread_interface=\"frictionless\"",
                                                              "loading.displacement_mm=12"), "a large pull"))
    cones = _interface_cases("cones", "cone")
    cones.insert(5, Case("cones: sliding, 12 mm", 7, (*MOVED, "effects.cone_interface=\"sliding\"",
                                                      "loading.displacement_mm=12"), "a large pull, bilateral"))
    free = Case("nothing tied: sliding thread, coulomb cones mu 0.3, 8 mm", 7,
                (*MOVED, "effects.thread_interface=\"sliding\"", "effects.cone_interface=\"coulomb\"",
                 "effects.friction_coefficient=0.3", "loading.displacement_mm=8"), "the device's model, nothing tied")
    return thread + cones + [free]


def _interface_cases(label: str, part: str) -> list[Case]:
    """Coulomb on one interface (``effects.{part}_interface``): friction 0 to 1, a large pull, soft tissue, fillets."""
    coulomb = f"effects.{part}_interface=\"coulomb\""
    cases = [Case(f"{label}: coulomb mu {mu:g}, 6 mm", 7, (*MOVED, coulomb, f"effects.friction_coefficient={mu:g}",
                                                           "loading.displacement_mm=6"), "friction coefficient")
             for mu in (0.0, 0.1, 0.5, 1.0)]
    cases.append(Case(f"{label}: coulomb, 12 mm", 7, (*MOVED, coulomb, "loading.displacement_mm=12"),
                      "a large pull (the tied scene takes 12 N at about 9 mm)"))
    cases.append(Case(f"{label}: coulomb, soft tissue", 7, (*MOVED, coulomb, "materials.tissue_scale=0.3112",
                                                            "loading.displacement_mm=8"),
                      "the calibrated tissue scale of docs/reproduction.md"))
    cases.append(Case(f"{label}: coulomb, filleted rims", 7, (*MOVED, coulomb, "geometry.cone_fillet_mm=0.05",
                                                              "loading.displacement_mm=6"), "rounded cone rims"))
    return cases


def poisson(factor: float) -> float:
    """Initial Poisson ratio of the hypodermis (mu = 2 c10 = 800 Pa, K = 2/d1) at 1/d times factor."""
    K, mu = 2 * PAPER_INV_D * factor, 800.0
    return (3 * K - 2 * mu) / (2 * (3 * K + mu))


#: The fast subset (coarse, degree 1, a few seconds each) that tests/stability runs.
FAST = ("mesh.degree=1", "mesh.refinement=0")
FAST_SUBSET: dict[str, tuple[str, ...]] = {
    "paper P1 1 N": (*FAST, "loading.force_n=1.0", "loading.report_forces_n=[]"),
    "K x1000 P1 displacement": (*bulk(1000), *FAST, "loading.force_n=0.5", "loading.report_forces_n=[]"),
    "suture E = 1.5e+07 Pa": ("materials.suture.young=1.5e7", *FAST, "loading.force_n=1.0",
                              "loading.report_forces_n=[]"),
    "12 N, 1 cone, P1": ("loading.force_n=12", "geometry.cones=1", *FAST, "loading.report_forces_n=[]"),
    "Gent jm = 0.05": ("materials.epidermis.jm=0.05", *FAST, "loading.report_forces_n=[]"),
    "contact: coulomb mu 1, 1 cone": (*MOVED, "effects.thread_interface=\"coulomb\"", "geometry.cones=1",
                                      "effects.friction_coefficient=1", "loading.displacement_mm=3"),
}


def classify(results: dict[str, Any] | None, exit_code: int | None) -> dict[str, Any]:
    """One table row from a run's results.json and exit code (None: the run timed out)."""
    row: dict[str, Any] = {"exit_code": exit_code}
    if exit_code is None:
        return {**row, "outcome": "FAILED", "why": "no answer within the time limit (hang)"}
    if results is None:
        return {**row, "outcome": "FAILED", "why": "no results.json"}
    outputs = [results.get(k) for k in ("usum_mm", "seqv_pa", "eptoeqv")]
    finite = all(isinstance(v, (int, float)) and math.isfinite(v) for v in outputs)
    row.update({
        "status": results.get("status"),
        "load_reached_n": results.get("force_reached_n", 0.0),
        "applied_force_n": results.get("applied_force_n"),
        # what the ramp was to reach and what it reached: the force, or (displacement control) the end's displacement
        "target": results.get("applied_force_n", results.get("applied_displacement_mm")),
        "reached": (results.get("force_reached_n", 0.0) if "applied_force_n" in results
                    else results.get("thread_end_displacement_mm")),
        "newton_iterations": results.get("newton_iterations"),
        "cutbacks": results.get("cutbacks"),
        "domain_rejections": results.get("domain_rejections"),
        "residual_floor_n": results.get("residual_floor_n"),
        "load_steps": results.get("load_steps"),
        "unknowns": results.get("unknowns"),
        "usum_mm": results.get("usum_mm"),
        "tissue_seqv_pa": (results.get("regions") or {}).get(WHOLE_TISSUE, {}).get("seqv_pa"),
        "eptoeqv": results.get("eptoeqv"),
        "force_balance_rel": results.get("force_balance_rel"),
        "wall_time_s": results.get("wall_time_s"),
        "cause": (results.get("diagnosis") or {}).get("cause"),
        "detail": (results.get("diagnosis") or {}).get("detail"),
    })
    balanced = isinstance(row["force_balance_rel"], float) and row["force_balance_rel"] < BALANCE_TOL
    if exit_code == 0 and row["status"] == "converged" and finite and balanced:
        row["outcome"] = "converged"
    elif exit_code == 3 and row["status"] == "stopped" and row["cause"] in CAUSES and (
            row["load_reached_n"] == 0.0 or (finite and balanced)):
        row["outcome"] = "stopped"
    else:
        row["outcome"] = "FAILED"
        row["why"] = (f"exit {exit_code}, status {row['status']}, finite outputs {finite}, "
                      f"balance {row['force_balance_rel']}, cause {row['cause']}")
    return row


def _run_inprocess(overrides: tuple[str, ...], out: Path, comm: Any) -> int:
    """The case in this process (what ``suture-fem run`` does); returns its exit code."""
    from suture_fem.pipeline import load_scene, run_scene
    from suture_fem.support.errors import SutureFemError

    try:
        run_scene(load_scene("paper", list(overrides)), out, comm)
    except SutureFemError as exc:
        return exc.exit_code
    return 0


def run_case(name: str, overrides: tuple[str, ...], out: Path, *, inprocess: bool = False,
             timeout_s: float | None = None, comm: Any = None) -> dict[str, Any]:
    """Run one case (``suture-fem run paper --set ...``) and classify it.

    In process it runs on ``comm`` (default: this process alone); otherwise as a subprocess.
    """
    out = Path(out)
    args = ["run", "paper", *[a for o in overrides for a in ("--set", o)], "--out", str(out)]
    t0 = time.perf_counter()
    if inprocess:
        if comm is None:
            from mpi4py import MPI

            comm = MPI.COMM_SELF
        code: int | None = _run_inprocess(overrides, out, comm)
    else:
        try:
            code = subprocess.run([sys.executable, "-P", "-m", "suture_fem.cli", *args], capture_output=True,
                                  text=True, timeout=timeout_s).returncode
        except subprocess.TimeoutExpired:
            code = None
    path = out / "results.json"
    results = json.loads(path.read_text()) if path.is_file() else None
    return {"case": name, "overrides": list(overrides), **classify(results, code),
            "process_time_s": time.perf_counter() - t0}


COLUMNS = (("case", "case", "{}"), ("outcome", "outcome", "{}"), ("cause", "cause", "{}"),
           ("load_reached_n", "load reached (N)", "{:.4g}"), ("newton_iterations", "Newton its", "{}"),
           ("cutbacks", "cutbacks", "{}"), ("domain_rejections", "rejected trials", "{}"),
           ("residual_floor_n", "residual floor (N)", "{:.1e}"), ("usum_mm", "USUM (mm)", "{:.4f}"),
           ("unknowns", "unknowns", "{}"),
           ("wall_time_s", "wall time (s)", "{:.1f}"))


def markdown(rows: list[dict[str, Any]]) -> str:
    """The matrix as a Markdown table."""
    lines = ["| " + " | ".join(h for _, h, _ in COLUMNS) + " |", "|" + " --- |" * len(COLUMNS)]
    for row in rows:
        cells = []
        for key, _, fmt in COLUMNS:
            v = row.get(key)
            cells.append("-" if v is None else fmt.format(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def locking_table(rows: list[dict[str, Any]]) -> str:
    """Case 1: USUM, EPTOEQV and tissue SEQV against the bulk modulus for each formulation (Markdown)."""
    by = {r["case"]: r for r in rows}
    head = ("| 1/d factor | nu (hypodermis) | P1 displacement | P2 displacement | P2/P1 mixed |\n"
            "| --- | --- | --- | --- | --- |")
    lines = [head]
    for factor in (1, 10, 100, 1000):
        cells = []
        for d, f in ((1, "displacement"), (2, "displacement"), (2, "mixed")):
            r = by.get(f"K x{factor} P{d} {f}")
            if r is None:
                cells.append("-")
            elif r["outcome"] == "converged":
                cells.append(f"{r['usum_mm']:.4f} mm / {r['eptoeqv']:.3f} / {r['tissue_seqv_pa'] / 1e3:.0f} kPa "
                             f"({r['newton_iterations']} its)")
            else:
                cells.append(f"{r['outcome']} ({r.get('cause')}) at {r.get('load_reached_n', 0):.3g} N")
        lines.append(f"| x{factor} | {poisson(factor):.6f} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n\nEach cell: USUM / EPTOEQV / tissue SEQV (Newton iterations).\n"
