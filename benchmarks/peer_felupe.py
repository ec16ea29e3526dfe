"""The paper scene in FElupe (a peer code), on our mesh with our energies, supports, load and tolerance.

FElupe (PyPI ``felupe``, with ``tensortrax`` for energies written as functions of C: the optional extra
``peer``; never a test dependency) solves the same discrete problem as ``suture-fem run paper --set
mesh.degree=1`` (or 2):

* Mesh: the same gmsh model (suture_fem's own mesher, :func:`gmsh_mesh`), linear triangles, in metres.
  FElupe's axisymmetric field takes x_1 = axial, x_2 = radial, so the points are (z, r) and each
  triangle's node order is flipped to keep it counter-clockwise. P2: FElupe adds the edge midpoints
  (our P2 dofs on these straight-sided triangles) and uses :func:`corrected_quadratic_triangle`.
* Quadrature: FElupe's 3-point triangle rule (degree 2), the same points and weights as basix's
  degree-2 rule that our P1 forms use (``physics.forms.quadrature_degree``); at P2 basix's degree-4
  rule itself, as a FElupe ``Scheme``.
* Energies (:func:`energy_functions`): Yeoh, Gent and St Venant-Kirchhoff exactly as
  ``physics/materials.py`` writes them (ANSYS forms, ``materials.tissue_scale`` on every tissue
  constant), written as tensortrax functions of C = F^T F; FElupe differentiates them (hyper-dual
  numbers) for the stress and the tangent. One ``SolidBody`` per material region, all linked to one field.
* Supports: u = 0 on the outer epidermis surface, u_r = 0 on the axis (``physics/constraints.py``).
* Load: a dead axial force F on the thread's end face, as the consistent nodal forces of the traction
  F / (pi r_t^2) weighted by 2 pi r (exact on linear and quadratic edges), a ``PointLoad``.
* Admissible states: FElupe's line search rejects det F <= 0; :meth:`Model.inside_gent_limit` adds
  I1bar - 3 < Jm in the Gent epidermis, as our domain guard has it (without it FElupe's P2 ramp
  converged past the limit).
* Stepping: a ``Step`` with substeps at 0 N and at the report forces 1, 2, 3, 4 N, FElupe's
  ``LinesearchPlugin`` (admissible J > 0 and sufficient decrease of the residual) and ``CutbackPlugin``
  (halve a failed substep, grow by 2 after a converged one), at most 25 Newton iterations per solve
  (``solver.max_iterations``). The 0 N substep converges in its one iteration (counted); without it the
  plugin cannot subdivide the first substep. Newton iterations count every iteration, failed attempts too.
* Newton tolerance (:func:`residual_check`): the free residual's 2-norm at most 1e-9 of the applied
  force (N), floored at ``solver.atol`` (1e-10 N). Ours (``solve/newton.py``) stops on a relative 1e-9,
  an absolute max(1e-10 N, round-off floor), or an increment below 1e-7 of the state with the residual
  at most 1e-9 of the force; at 4 N both codes end near 1e-10 N (the table of docs/peer.md).
* Linear solver: FElupe's default, scipy's ``spsolve`` (SuperLU) on the free dofs.

``--child`` runs one solve in this process and writes a JSON with its results and the process CPU time
(``time.process_time``) at each phase; ``benchmarks/peer_compare.py`` (``speed.py --peer``) starts it
as a child process beside ours, measures both by their rusage and first checks that the two codes
have the same strain energy and residual on the same mesh. FElupe 11.3's ``QuadraticTriangle`` has a
miscoded shape-function derivative: P2 (``--degree 2``) uses :func:`corrected_quadratic_triangle`.

    .venv/bin/python benchmarks/peer_felupe.py --child [--degree 2] [--substep N] --out X.json
"""

from __future__ import annotations

import time

T_START = time.process_time()

import argparse  # noqa: E402  (the process CPU time is read before any import)
import json  # noqa: E402
import math  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
#: Report forces of the 0-4 N ramp (N), the FElupe step's substeps.
FORCES_N = (1.0, 2.0, 3.0, 4.0)
#: Free-residual tolerance as a fraction of the applied force (``solve/newton.py`` INCREMENT_STOP_RESIDUAL).
RESIDUAL_RTOL = 1e-9
MM = 1e-3


@dataclass
class GmshMesh:
    """A linear triangle mesh in mm: points (r, z), triangles and boundary edges by tag."""

    points: np.ndarray
    cells: dict[int, np.ndarray]
    facets: dict[int, np.ndarray]


def scene(degree: int) -> Any:
    """The paper scene at this degree (suture_fem's scene loader: defaults, built-in scene, overrides)."""
    from suture_fem.scene import parse_scene

    return parse_scene("paper", [f"mesh.degree={degree}"])


def gmsh_mesh(sc: Any) -> GmshMesh:
    """Mesh the scene with suture_fem's gmsh model (the same code and mesh as ``suture-fem run``)."""
    import gmsh

    from suture_fem.geometry.gmsh_model import MeshSizes, build_gmsh_model
    from suture_fem.geometry.regions import CELL_TAGS, FACET_TAGS
    from suture_fem.geometry.section import Geometry
    from suture_fem.support import compat

    with compat.gmsh_session():
        try:
            build_gmsh_model(Geometry.from_section(sc.geometry), MeshSizes.from_section(sc.mesh))
            tags, xyz, _ = gmsh.model.mesh.getNodes()
            index = np.full(int(tags.max()) + 1, -1)
            index[tags.astype(int)] = np.arange(len(tags))

            def elements(dim: int, tag: int, nodes: int) -> np.ndarray:
                out = [gmsh.model.mesh.getElements(dim, e)[2] for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)]
                flat = np.concatenate([a for o in out for a in o]) if out else np.zeros(0)
                return index[flat.astype(int)].reshape(-1, nodes)

            cells = {t: elements(2, t, 3) for t in CELL_TAGS.values()}
            facets = {t: elements(1, t, 2) for t in FACET_TAGS.values()}
        finally:
            gmsh.model.remove()
    return GmshMesh(xyz.reshape(-1, 3)[:, :2].copy(), {t: c for t, c in cells.items() if len(c)}, facets)


def energy_functions(sc: Any) -> dict[str, Any]:
    """Region -> W(C) as a tensortrax function, exactly the energies of ``physics/materials.py``."""
    import tensortrax.math as tm

    s = sc.materials.tissue_scale

    def invariants(C: Any) -> tuple[Any, Any]:
        J = tm.sqrt(tm.linalg.det(C))
        return J, J ** (-2.0 / 3.0) * tm.trace(C)

    def yeoh(p: dict[str, float]) -> Any:
        c = [p.get(f"c{i}0", 0.0) for i in range(1, 7)]
        d = [p.get(f"inv_d{k}", 0.0) for k in range(1, 7)]

        def W(C: Any) -> Any:
            J, i1 = invariants(C)
            iso = sum(ci * (i1 - 3) ** (i + 1) for i, ci in enumerate(c) if ci != 0.0)
            vol = sum(dk * (J - 1) ** (2 * (k + 1)) for k, dk in enumerate(d) if dk != 0.0)
            return s * (iso + vol)
        return W

    def gent(p: dict[str, float]) -> Any:
        mu, jm, d = p["mu"], p["jm"], p["inv_d"]

        def W(C: Any) -> Any:
            J, i1 = invariants(C)
            return s * (-0.5 * mu * jm * tm.log(1 - (i1 - 3) / jm) + d * ((J**2 - 1) / 2 - tm.log(J)))
        return W

    def svk(p: dict[str, float]) -> Any:
        E, nu = p["young"], p["poisson"]
        lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))

        def W(C: Any) -> Any:
            G = (C - tm.base.eye(C)) / 2
            return 0.5 * lam * tm.trace(G) ** 2 + mu * tm.trace(G @ G)
        return W

    makers = {"yeoh": yeoh, "gent": gent, "svk": svk}
    out = {}
    for region in ("hypodermis", "dermis", "epidermis", "suture"):
        spec = sc.materials.of(region)
        params = {k: float(v) for k, v in spec.params.items() if isinstance(v, (int, float))}
        out[region] = makers[spec.model](params)
    return out


@dataclass
class Model:
    """The FElupe problem: the global field, one SolidBody per region, the pull and the supports."""

    field: Any
    solids: list[Any]
    load: Any
    boundaries: dict[str, Any]
    unit_force: np.ndarray
    points_rz_m: np.ndarray
    umats: dict[str, Any]
    gent_jm: dict[int, float]

    def inside_gent_limit(self, trial: Any) -> bool:
        """A ``LinesearchPlugin`` criterion: I1bar - 3 < Jm at every quadrature point of every Gent region.

        FElupe's line search checks only det F > 0. Gent's energy is undefined past its locking limit
        while the stress tensortrax derives from it stays finite there (d/dx ln(1 - x / Jm) =
        -1 / (Jm - x)), so without this criterion Newton can converge to a state past the limit (it
        did at P2: I1bar - 3 = 2.5 > Jm = 1.2 in an epidermis cell from 2 N on). Ours rejects such a trial
        in its domain guard (``solve/guard.py``).
        """
        for index, jm in self.gent_jm.items():
            solid = self.solids[index]
            solid.field.link(trial.x)
            F = solid.field.extract(grad=True)[0]
            C = np.einsum("kI...,kJ...->IJ...", F, F)
            with np.errstate(invalid="ignore"):
                i1 = np.linalg.det(np.moveaxis(C, (0, 1), (-2, -1))) ** (-1.0 / 3.0) * np.einsum("ii...->...", C)
            if not np.all(i1 - 3 < jm):
                return False
        return True


def corrected_quadratic_triangle() -> Any:
    """FElupe's QuadraticTriangle with its shape-function gradient corrected (FElupe 11.3 miscodes one entry).

    Node 5 (the midpoint of edge 2-0) has h_5 = 4 s (1 - r - s), so dh_5/ds = 4 (1 - r - 2 s); FElupe 11.3
    writes 4 (1 - 2 r - s) (``t1 - t2`` for ``t1 - t3``), which also reaches nodes 0 and 2 through the
    corner corrections. ``check_gradients`` shows the error and the fix by central differences.
    """
    import felupe as fem

    class QuadraticTriangleFixed(fem.QuadraticTriangle):
        def gradient(self, rs: Any) -> np.ndarray:
            r, s = rs
            t1 = 1 - r - s
            d = np.array([[-1, -1], [1, 0], [0, 1], [4 * (t1 - r), -4 * r], [4 * s, 4 * r], [-4 * s, 4 * (t1 - s)]],
                         dtype=float)
            d[0] += -d[3] / 2 - d[5] / 2
            d[1] += -d[3] / 2 - d[4] / 2
            d[2] += -d[4] / 2 - d[5] / 2
            return d

    return QuadraticTriangleFixed()


@dataclass
class Discrete:
    """Points (axial, radial) in m, counter-clockwise cells (3 or 6 nodes), rows of each region, element, rule."""

    points: np.ndarray
    cells: np.ndarray
    rows: dict[str, np.ndarray]
    element: Any
    quadrature: Any
    cell_type: str

    def edge_nodes(self, edges: np.ndarray) -> np.ndarray:
        """The nodes of linear edges (i, j): (i, j), or (i, m, j) with the midpoint m at degree 2."""
        if self.cell_type == "triangle":
            return edges
        from scipy.spatial import cKDTree

        dist, mid = cKDTree(self.points).query(0.5 * (self.points[edges[:, 0]] + self.points[edges[:, 1]]))
        assert dist.max() < 1e-12, "every edge has its midpoint node"
        return np.stack([edges[:, 0], mid, edges[:, 1]], axis=1)


def discretise(sc: Any, gm: GmshMesh) -> Discrete:
    """FElupe's mesh of the gmsh mesh at the scene's degree: P1, or P2 (midpoints added, corrected element)."""
    import felupe as fem

    from suture_fem.geometry.regions import REGION_TAGS

    points = np.ascontiguousarray(gm.points[:, ::-1] * MM)  # FElupe axisymmetric: (axial, radial)
    order = [(region, t) for region, tags in REGION_TAGS.items() for t in tags if t in gm.cells]
    cells = np.concatenate([gm.cells[t] for _, t in order])
    assert len(np.unique(cells)) == len(points), "every gmsh node belongs to a triangle"
    a, b, c = (points[cells[:, k]] for k in range(3))
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    cells = np.where(cw[:, None], cells[:, [0, 2, 1]], cells)  # (r, z) -> (z, r) mirrors: counter-clockwise
    ends = np.cumsum([0] + [len(gm.cells[t]) for _, t in order])
    rows: dict[str, list[np.ndarray]] = {}
    for (region, _), lo, hi in zip(order, ends[:-1], ends[1:]):
        rows.setdefault(region, []).append(np.arange(lo, hi))
    merged = {region: np.concatenate(r) for region, r in rows.items()}
    if sc.mesh.degree == 1:
        return Discrete(points, cells, merged, fem.Triangle(), fem.TriangleQuadrature(order=2), "triangle")
    import basix

    mesh = fem.Mesh(points, np.ascontiguousarray(cells), "triangle").add_midpoints_edges()
    # our P2 forms' rule (quadrature degree 4, basix): FElupe's triangle rules stop at order 3 and 5
    qp, qw = basix.make_quadrature(basix.CellType.triangle, 4)
    return Discrete(mesh.points, mesh.cells, merged, corrected_quadratic_triangle(),
                    fem.quadrature.Scheme(qp, qw), "triangle6")


def felupe_model(sc: Any, gm: GmshMesh) -> Model:
    """The FElupe problem on the mesh: fields, solids, supports, the pull per newton of force."""
    import felupe as fem

    from suture_fem.geometry.regions import Facet

    d = discretise(sc, gm)

    def field_on(cells: np.ndarray) -> Any:
        region = fem.Region(fem.Mesh(d.points, np.ascontiguousarray(cells), d.cell_type), d.element, d.quadrature)
        return fem.FieldContainer([fem.FieldAxisymmetric(region, dim=2)])

    field = field_on(d.cells)
    functions = energy_functions(sc)
    solids, umats = [], {}
    for region, rows in d.rows.items():
        sub = field_on(d.cells[rows])
        sub.link(field)
        umats[region] = fem.Hyperelastic(functions[region])
        solids.append(fem.SolidBody(umats[region], sub))
    rz = np.ascontiguousarray(d.points[:, ::-1])
    unit = pull_forces(rz, d.edge_nodes(gm.facets[Facet.PULL_FACE]), sc.geometry.thread_radius_mm * MM)
    load = fem.PointLoad(field, np.arange(len(d.points)), values=np.zeros_like(d.points))
    masks = {}
    for name, tag in (("outer", Facet.OUTER), ("axis", Facet.AXIS)):
        masks[name] = np.zeros(len(d.points), bool)
        masks[name][d.edge_nodes(gm.facets[tag]).ravel()] = True
    boundaries = {
        "outer": fem.Boundary(field[0], mask=masks["outer"]),
        "axis": fem.Boundary(field[0], mask=masks["axis"], skip=(1, 0)),  # u_r (component 2) = 0
    }
    gent = {i: float(sc.materials.of(region).params["jm"]) for i, region in enumerate(umats)
            if sc.materials.of(region).model == "gent"}
    return Model(field, solids, load, boundaries, unit, rz, umats, gent)


def pull_forces(rz: np.ndarray, edges: np.ndarray, r_thread: float) -> np.ndarray:
    """Nodal forces (axial, radial) of a 1 N axial pull: traction 1 / (pi r_t^2) on the end face's edges.

    The integral of t N_a 2 pi r ds over each straight edge (nodes i, j or i, m, j; N_a linear or
    quadratic, r linear) by 3-point Gauss-Legendre, exact for these polynomials as our forms' facet
    quadrature is.
    """
    t = 1.0 / (math.pi * r_thread**2)
    xi, w = np.polynomial.legendre.leggauss(3)
    xi, w = (xi + 1) / 2, w / 2  # on [0, 1]
    if edges.shape[1] == 2:
        shape = np.stack([1 - xi, xi])
    else:
        shape = np.stack([(1 - xi) * (1 - 2 * xi), 4 * xi * (1 - xi), xi * (2 * xi - 1)])
    f = np.zeros_like(rz)
    for nodes in edges:
        i, j = nodes[0], nodes[-1]
        length = float(np.hypot(*(rz[i] - rz[j])))
        r = rz[i, 0] * (1 - xi) + rz[j, 0] * xi
        np.add.at(f[:, 0], nodes, t * 2 * math.pi * length * (shape * r * w).sum(axis=1))
    return f


def strain_energy(model: Model) -> float:
    """FElupe's strain energy (J): W(C) of each region at its quadrature points, integrated with 2 pi R dA."""
    import tensortrax as tr

    total = 0.0
    for solid in model.solids:
        solid.field.link(model.field)  # the unknowns (a line search may have left the solid on its last trial)
        F = solid.field.extract(grad=True)[0]
        C = np.einsum("kI...,kJ...->IJ...", F, F)
        W = tr.function(solid.umat.fun, wrt=0, ntrax=2)(C)
        dA = solid.field.region.dV
        total += float(np.sum(W * 2 * np.pi * solid.field[0].radius * dA))
    return total


def residual_check(model: Model) -> Any:
    """FElupe's ``check``: converged when ||r_free||_2 <= max(1e-9 F, 1e-10 N), F the force applied now."""

    def check(dx: Any, x: Any, f: Any, xtol: float, ftol: float, dof1: Any = None, dof0: Any = None,
              items: Any = None, eps: float = 1e-3) -> tuple[float, float, bool]:
        force = float(np.sum(model.load.values[:, 0]))
        fnorm = float(np.linalg.norm(f[dof1]))
        return float(np.linalg.norm(dx)), fnorm, bool(fnorm <= max(RESIDUAL_RTOL * abs(force), 1e-10))
    return check


def usum_mm(model: Model) -> float:
    """USUM: the largest |u| over the mesh nodes (mm), as ``outputs/usum.py`` takes it."""
    return float(np.max(np.linalg.norm(model.field[0].values, axis=1)) / MM)


def solve(model: Model, max_iterations: int, substep_n: float = 1.0) -> dict[str, Any]:
    """The 0-4 N ramp in FElupe: substeps at the report forces, line search, cutbacks; USUM at each force."""
    import felupe as fem

    class Record(fem.Plugin):
        """Newton iterations (every one, in failed attempts too) and USUM at each converged substep."""

        def __init__(self) -> None:
            self.iterations = self.failed = 0
            self.increments: list[float] = []
            self.rows: list[dict[str, Any]] = []

        def after_iteration(self, context: Any, state: Any) -> None:
            self.iterations += 1

        def after_newton(self, context: Any, state: Any) -> None:
            self.increments.append(float(np.sum(model.load.values[:, 0])))

        def after_substep(self, context: Any, state: Any) -> None:
            if np.sum(model.load.values[:, 0]) == 0.0:
                return
            self.rows.append({"force_n": float(np.sum(model.load.values[:, 0])), "usum_mm": usum_mm(model),
                              "strain_energy_j": strain_energy(model), "residual_n": float(state.result.fnorms[-1])})

    record = Record()
    # a first substep at 0 N (converged at once: one Newton iteration, counted) gives the CutbackPlugin the
    # previous values it needs to subdivide the first real substep (0 -> 1 N fails at P2)
    forces = np.unique(np.concatenate([np.arange(0.0, FORCES_N[-1], substep_n), FORCES_N]))
    ramp = np.array([f * model.unit_force for f in forces])
    step = fem.Step(items=[*model.solids, model.load], ramp={model.load: ramp}, boundaries=model.boundaries)
    cutback = fem.CutbackPlugin(factor=0.5, growth=2.0, max_cutbacks=10)
    search = fem.LinesearchPlugin(criteria=[model.inside_gent_limit])
    job = fem.Job(steps=[step], plugins=[search, cutback, record])
    job.evaluate(x0=model.field, check=residual_check(model), maxiter=max_iterations, verbose=0)
    return {"newton_iterations": record.iterations, "solves": len(record.increments),
            "cutbacks": int(sum(cutback.cutbacks)), "load_factors": cutback.load_factors,
            "at_forces": record.rows, "usum_mm": record.rows[-1]["usum_mm"] if record.rows else None}


def child(out: Path, degree: int, substep_n: float = 1.0, save: Path | None = None) -> None:
    """One FElupe solve of the paper scene in this process; the process CPU at each phase to ``out``."""
    cpu = {"start": T_START}
    import felupe  # noqa: F401
    import tensortrax  # noqa: F401
    cpu["imports"] = time.process_time()
    sc = scene(degree)
    gm = gmsh_mesh(sc)  # imports suture_fem's mesher (and, through it, dolfinx), as ours does
    cpu["meshing"] = time.process_time()
    model = felupe_model(sc, gm)
    cpu["setup"] = time.process_time()
    result = solve(model, sc.solver.max_iterations, substep_n)
    result["degree"] = degree
    cpu["solve"] = time.process_time()
    phases = dict(zip(list(cpu)[1:], np.diff(list(cpu.values())).tolist()))
    _, free = felupe.dof.partition(model.field, model.boundaries)
    result.update({"cpu_phases_s": phases, "nodes": len(gm.points), "unknowns": int(len(free)),
                   "felupe": felupe.__version__, "linear_solver": "scipy.sparse.linalg.spsolve (SuperLU)"})
    out.write_text(json.dumps(result, indent=1))
    if save is not None:  # the converged state at 4 N, for a look at it (not part of the measurement)
        np.savez(save, points_rz_m=model.points_rz_m, u_zr_m=model.field[0].values)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--child", action="store_true", help="solve the ramp in FElupe in this process")
    ap.add_argument("--degree", type=int, choices=(1, 2), default=1,
                    help="P1, or P2 with the corrected quadratic triangle (see corrected_quadratic_triangle)")
    ap.add_argument("--substep", type=float, default=1.0,
                    help="FElupe's substep (N; the report forces are always substeps)")
    ap.add_argument("--save", default=None, help="also write the state at 4 N to this .npz")
    ap.add_argument("--out", default=None, help="JSON output path")
    args = ap.parse_args()
    if not args.child:
        ap.error("give --child (the comparison and the checks: benchmarks/peer_compare.py, speed.py --peer)")
    child(Path(args.out or ROOT / "benchmarks/out/peer_felupe_child.json"), args.degree, args.substep,
          Path(args.save) if args.save else None)


if __name__ == "__main__":
    main()
