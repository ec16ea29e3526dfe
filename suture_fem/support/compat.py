"""Every difference between the dolfinx / gmsh / petsc4py versions we run on, in one place.

Written against Debian bookworm (dolfinx 0.5.2, ufl 2022.2, petsc4py 3.18, gmsh 4.8). The newer
spellings (dolfinx >= 0.7 / 0.9, gmsh >= 4.11) are selected by feature tests, so supporting Debian
trixie's dolfinx 0.9 stays a change to this module only.
"""

from __future__ import annotations

import hashlib
import inspect
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.io
import numpy as np

from suture_fem.support.logging import announce_if_nothing_cached

try:  # dolfinx 0.5-0.6 ship gmshio as a submodule that must be imported explicitly
    from dolfinx.io import gmshio as _gmshio
except ImportError:  # pragma: no cover
    _gmshio = dolfinx.io.gmshio

DOLFINX_VERSION: str = dolfinx.__version__
_V = tuple(int(p) for p in DOLFINX_VERSION.split(".")[:2])

try:
    import gmsh as _gmsh

    GMSH_HAS_INTERRUPTIBLE = "interruptible" in inspect.signature(_gmsh.initialize).parameters
except ImportError:  # pragma: no cover
    GMSH_HAS_INTERRUPTIBLE = False


def vector_space(mesh: Any, degree: int) -> Any:
    """Continuous Lagrange space of 2-vectors."""
    if hasattr(dolfinx.fem, "VectorFunctionSpace"):
        return dolfinx.fem.VectorFunctionSpace(mesh, ("Lagrange", degree))
    return dolfinx.fem.functionspace(mesh, ("Lagrange", degree, (mesh.geometry.dim,)))  # pragma: no cover


def scalar_space(mesh: Any, family: str, degree: int) -> Any:
    """Scalar space of a family ("Lagrange", "DG")."""
    if hasattr(dolfinx.fem, "FunctionSpace") and _V < (0, 8):
        return dolfinx.fem.FunctionSpace(mesh, (family, degree))
    return dolfinx.fem.functionspace(mesh, (family, degree))  # pragma: no cover


def mixed_space(mesh: Any, degree_u: int, degree_p: int) -> Any:
    """Taylor-Hood-type space [P_k]^d x P_{k-1} (displacement, pressure), d the mesh's dimension."""
    import ufl

    if _V < (0, 7):
        ve = ufl.VectorElement("Lagrange", mesh.ufl_cell(), degree_u)
        pe = ufl.FiniteElement("Lagrange", mesh.ufl_cell(), degree_p)
        return dolfinx.fem.FunctionSpace(mesh, ufl.MixedElement([ve, pe]))
    import basix.ufl  # pragma: no cover

    ve = basix.ufl.element("Lagrange", mesh.basix_cell(), degree_u, shape=(mesh.geometry.dim,))  # pragma: no cover
    pe = basix.ufl.element("Lagrange", mesh.basix_cell(), degree_p)  # pragma: no cover
    return dolfinx.fem.functionspace(mesh, basix.ufl.mixed_element([ve, pe]))  # pragma: no cover


def cell_dofs(space: Any) -> np.ndarray:
    """The dofmap as a 2-D array (local cell, dof of the cell); blocked spaces list nodes.

    dolfinx 0.5-0.6 return an AdjacencyList (flattened in ``.array``); from 0.7 on it is a 2-D array.
    """
    dofmap = space.dofmap.list
    if hasattr(dofmap, "array") and not isinstance(dofmap, np.ndarray):
        return dofmap.array.reshape(-1, space.dofmap.dof_layout.num_dofs)
    return np.asarray(dofmap)  # pragma: no cover (dolfinx >= 0.7)


def geometry_dofs(mesh: Any) -> np.ndarray:
    """The geometry dofmap as a 2-D array (local cell, its geometry nodes: 3 for a straight triangle)."""
    dofmap = mesh.geometry.dofmap
    if hasattr(dofmap, "array") and not isinstance(dofmap, np.ndarray):
        per_cell = int(dofmap.offsets[1] - dofmap.offsets[0]) if dofmap.num_nodes else 3
        return dofmap.array.reshape(-1, per_cell)
    return np.asarray(dofmap)  # pragma: no cover (dolfinx >= 0.7)


def function_vector(u: Any) -> Any:
    """The PETSc vector behind a Function."""
    return u.vector if hasattr(u, "vector") and not callable(u.vector) else u.x.petsc_vec


def gmsh_model_to_mesh(model: Any, comm: Any, rank: int, gdim: int) -> tuple[Any, Any, Any]:
    """(mesh, cell_tags, facet_tags) from a gmsh model held on ``rank``."""
    out = _gmshio.model_to_mesh(model, comm, rank, gdim=gdim)
    return out[0], out[1], out[2]


def gmsh_set_distance_sampling(field_tag: int, n: int) -> None:
    """Points per curve of a gmsh Distance field (renamed "Sampling" in gmsh 4.11)."""
    import gmsh

    try:
        gmsh.model.mesh.field.setNumber(field_tag, "Sampling", n)
    except Exception:
        gmsh.model.mesh.field.setNumber(field_tag, "NumPointsPerCurve", n)


def gmsh_distance_surfaces(field_tag: int, surfaces: list[int]) -> None:
    """The surfaces of a gmsh Distance field ("FacesList" before gmsh 4.9, then "SurfacesList")."""
    import gmsh

    try:
        gmsh.model.mesh.field.setNumbers(field_tag, "SurfacesList", surfaces)
    except Exception:
        gmsh.model.mesh.field.setNumbers(field_tag, "FacesList", surfaces)


#: C compiler flags for every generated form and expression kernel. -O3 (not the default -O2) cuts the
#: residual assembly of the paper scene by about a quarter and the Jacobian's by about a tenth
#: (benchmarks/speed.py). No -ffast-math or -Ofast: they let the compiler assume that no value is NaN
#: or Inf, and the admissible-domain guard (suture_fem/solve/guard.py) must see non-finite values.
#: No -march=native either: the kernel cache (~/.cache/fenics) may be shared between machines.
JIT_COMPILE_ARGS: tuple[str, ...] = ("-O3", "-g0")


def _no_parameter_files() -> tuple[dict[str, Any], dict[str, Any]]:
    """What the JIT's parameter files say, as seen by the package: nothing (see :func:`ignore_jit_files`)."""
    return {}, {}


def ignore_jit_files() -> None:
    """Make dolfinx and FFCx ignore their JSON parameter files (in the current folder and the user's).

    dolfinx reads ``dolfinx_jit_parameters.json`` (0.5-0.6; ``dolfinx_jit_options.json`` from 0.7) and
    FFCx ``ffcx_parameters.json`` (``ffcx_options.json`` from 0.7) from the current folder and from
    ``$XDG_CONFIG_HOME``, each through a cached loader (``_load_parameters`` / ``_load_options``); such a
    file moves the kernel cache (a shared library there is loaded and run) or changes how every form
    is compiled. The package sets its compiler options itself (:data:`JIT_COMPILE_ARGS`); the cache
    stays ``$XDG_CACHE_HOME/fenics`` (``~/.cache/fenics``).
    """
    import importlib

    for name in ("dolfinx.jit", "ffcx.parameters", "ffcx.options"):
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        for loader in ("_load_parameters", "_load_options"):
            if hasattr(module, loader):
                setattr(module, loader, _no_parameter_files)


ignore_jit_files()


def _jit_params() -> dict[str, Any]:
    key = "jit_params" if "jit_params" in inspect.signature(dolfinx.fem.form).parameters else "jit_options"
    return {key: {"cffi_extra_compile_args": list(JIT_COMPILE_ARGS)}}


def form(ufl_form: Any) -> Any:
    """A compiled dolfinx form, its kernels built with :data:`JIT_COMPILE_ARGS`."""
    announce_if_nothing_cached()
    return dolfinx.fem.form(ufl_form, **_jit_params())


def quadrature_points(cell: str, degree: int) -> np.ndarray:
    """Reference quadrature points of a rule exact to ``degree`` on a cell ("triangle" or "tetrahedron")."""
    return quadrature_rule(cell, degree)[0]


def quadrature_rule(cell: str, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference quadrature points and weights of a rule exact to ``degree`` on a cell (basix's default rule)."""
    import basix

    pts, weights = basix.make_quadrature(getattr(basix.CellType, cell), degree)
    return np.asarray(pts), np.asarray(weights)


def expression(expr: Any, points: np.ndarray) -> Any:
    """A compiled dolfinx Expression at reference points."""
    announce_if_nothing_cached()
    return dolfinx.fem.Expression(expr, points, **_jit_params())


def eval_expression(compiled: Any, mesh: Any, cells: np.ndarray) -> np.ndarray:
    """Evaluate an Expression on local cells: array (num_cells, num_points * value_size)."""
    if _V < (0, 7):
        return compiled.eval(cells)
    return compiled.eval(mesh, cells)  # pragma: no cover


def cell_locator(mesh: Any, cells: np.ndarray) -> Any:
    """A function of points (m, 3): (point index, cell) of every one of the given local cells containing each point.

    A point on a shared edge is in both cells. Built once (a bounding-box tree of ``cells``). Each point's
    cells do not depend on the other points asked with it. ``locate(points, keep=False)``: the point set
    is not kept for a later call with the same points.
    """
    import dolfinx.geometry as geo

    cells = np.asarray(cells, dtype=np.int32)
    tdim = mesh.topology.dim
    if len(cells) == 0:
        return lambda points, keep=True: (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int32))
    if hasattr(geo, "bb_tree"):  # pragma: no cover
        tree = geo.bb_tree(mesh, tdim, cells)
        collide = geo.compute_collisions_points
    else:
        tree = geo.BoundingBoxTree(mesh, tdim, cells)
        collide = geo.compute_collisions

    affine = _affine_triangles(mesh, cells) or _affine_tetrahedra(mesh, cells)

    found: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # the same points again (a search's fixed grid)

    def locate(points: np.ndarray, keep: bool = True) -> tuple[np.ndarray, np.ndarray]:
        points = np.ascontiguousarray(points, dtype=np.float64)
        if not keep:  # the caller keeps what it needs (outputs.disc.DiscPoints)
            return _locate(points)
        key = hashlib.blake2b(points.tobytes(), digest_size=16).digest()
        if key not in found:
            if len(found) >= _LOCATED_KEPT:
                found.pop(next(iter(found)))
            idx, cells_hit = _locate(points)
            idx.setflags(write=False)
            cells_hit.setflags(write=False)
            found[key] = (idx, cells_hit)
        return found[key]

    def _locate(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        candidates = collide(tree, points)
        if affine is None:
            hits = geo.compute_colliding_cells(mesh, candidates, points)
            return np.repeat(np.arange(len(points)), np.diff(hits.offsets)), np.asarray(hits.array, dtype=np.int32)
        idx = np.repeat(np.arange(len(points)), np.diff(candidates.offsets))
        cand = np.asarray(candidates.array, dtype=np.int32)
        inside = affine(points[idx], cand)
        return idx[inside], cand[inside]

    return locate


#: Point sets whose cells a locator keeps (the critical-distance search asks for the same disc points
#: again at every report force and for every quantity: on the paper scene 360 calls, 109 distinct sets,
#: 4.1 million points located for 1.1 million distinct ones).
_LOCATED_KEPT = 256
#: A point closer than this to a cell (m, as dolfinx's own collision test) counts as inside it.
_COLLISION_DISTANCE = 1e-10


def _affine_triangles(mesh: Any, cells: np.ndarray) -> Any:
    """A vectorised point-in-triangle test on the cells' vertex triangles (None for a mesh of other cells).

    dolfinx's ``compute_colliding_cells`` runs a GJK distance query per (point, candidate cell) pair,
    which made the critical-distance search cost more than the Newton solve of the paper scene
    (10 s of 24 s). For affine triangles the barycentric coordinates decide it exactly: a point is
    inside when no coordinate is below -d/h, h the cell's height over that edge, d
    :data:`_COLLISION_DISTANCE` (dolfinx's tolerance, so points on a shared edge are in both cells).
    Quadratic cells (``mesh.geometry_degree`` 2) are tested by their vertices' triangle too: exact for
    the straight ones, and for a cell on a fillet arc off by the sliver between the arc and its chord
    (its sagitta is under 1/200 of the fillet radius at 8 elements along a quarter circle); dolfinx's
    GJK test would be no better, as it tests the convex hull of the cell's nodes.
    """
    cmap = mesh.geometry.cmap
    if mesh.topology.dim != 2 or getattr(cmap, "degree", 1) > 2 or len(cells) == 0:
        return None
    x = mesh.geometry.x[:, :2][geometry_dofs(mesh)[:, :3]]  # (cells, 3 vertices, 2): a cell's vertices come first
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    inv = np.stack([np.stack([e2[:, 1], -e2[:, 0]], -1), np.stack([-e1[:, 1], e1[:, 0]], -1)], 1) / det[:, None, None]
    lengths = np.stack([np.hypot(*(x[:, 2] - x[:, 1]).T), np.hypot(*e2.T), np.hypot(*e1.T)], -1)
    heights = np.abs(det)[:, None] / lengths  # height over the edge opposite each vertex
    tol = _COLLISION_DISTANCE / heights

    def inside(points: np.ndarray, cand: np.ndarray) -> np.ndarray:
        local = np.einsum("nij,nj->ni", inv[cand], points[:, :2] - x[cand, 0])
        bary = np.column_stack([1.0 - local.sum(axis=1), local])
        return np.all(bary >= -tol[cand], axis=1)

    return inside


def _affine_tetrahedra(mesh: Any, cells: np.ndarray) -> Any:
    """:func:`_affine_triangles`' barycentric test for straight tetrahedra (None for a mesh of other cells).

    dolfinx's GJK query per (point, candidate cell) pair was two thirds of the 3-D critical-distance
    search's time; a point is inside when no barycentric coordinate is below -d/h, h the cell's height over
    the face opposite that vertex (3 V / the face's area), d :data:`_COLLISION_DISTANCE`.
    """
    if mesh.topology.dim != 3 or getattr(mesh.geometry.cmap, "degree", 1) != 1 or len(cells) == 0:
        return None
    x = mesh.geometry.x[geometry_dofs(mesh)[:, :4]]  # (cells, 4 vertices, 3)
    edges = np.stack([x[:, 1] - x[:, 0], x[:, 2] - x[:, 0], x[:, 3] - x[:, 0]], axis=2)  # columns: the edges
    det = np.linalg.det(edges)
    inv = np.linalg.inv(np.where(np.abs(det)[:, None, None] > 0, edges, np.eye(3)))
    faces = [(1, 2, 3), (0, 2, 3), (0, 1, 3), (0, 1, 2)]  # the face opposite each vertex
    areas = np.stack([0.5 * np.linalg.norm(np.cross(x[:, b] - x[:, a], x[:, c] - x[:, a]), axis=1)
                      for a, b, c in faces], axis=1)
    tol = _COLLISION_DISTANCE / (np.abs(det)[:, None] / 2.0 / np.maximum(areas, 1e-300))  # h = 3 V / A, V = |det| / 6

    def inside(points: np.ndarray, cand: np.ndarray) -> np.ndarray:
        local = np.einsum("nij,nj->ni", inv[cand], points - x[cand, 0])
        bary = np.column_stack([1.0 - local.sum(axis=1), local])
        return np.all(bary >= -tol[cand], axis=1)

    return inside


def vtk_mesh(space: Any) -> tuple[Any, Any, Any]:
    """(cells, cell types, points) of a function space's dof grid, for ``pyvista.UnstructuredGrid``.

    ``dolfinx.plot.create_vtk_mesh`` before 0.7, ``dolfinx.plot.vtk_mesh`` from 0.7 on.
    """
    import dolfinx.plot

    fn = getattr(dolfinx.plot, "vtk_mesh", None) or dolfinx.plot.create_vtk_mesh
    return fn(space)


def create_xdmf(comm: Any, path: str) -> Any:
    """An XDMF file opened for writing."""
    return dolfinx.io.XDMFFile(comm, path, "w")


def set_function_domain_error(snes: Any) -> bool:
    """Tell SNES the last function evaluation left the admissible domain, where petsc4py can.

    petsc4py 3.18 (Debian bookworm) has no ``SNES.setFunctionDomainError``; there the residual
    callback marks the state inadmissible by returning a huge finite residual (1e30 in every entry)
    instead, which the backtracking line search treats as a failed trial and shortens the step, and
    which makes a full-step Newton diverge at once (DIVERGED_DTOL) so the step is retried (solve/stepping.py).
    Returns True when the PETSc call was made.
    """
    fn = getattr(snes, "setFunctionDomainError", None)
    if fn is None:
        return False
    fn()  # pragma: no cover (petsc4py >= 3.19)
    return True


_gmsh_started_here = False


class gmsh_session:
    """Context manager: gmsh initialised for the block (and finalised only if it started it here).

    gmsh 4.8 has no ``gmsh.isInitialized``; newer versions do.
    """

    def __enter__(self) -> Any:
        import gmsh

        global _gmsh_started_here
        is_init = getattr(gmsh, "isInitialized", None)
        running = bool(is_init()) if is_init is not None else _gmsh_started_here
        self.owner = not running
        if self.owner:
            if GMSH_HAS_INTERRUPTIBLE:
                gmsh.initialize(interruptible=False)  # pragma: no cover (gmsh >= 4.10)
            else:
                gmsh.initialize()
            _gmsh_started_here = True
        gmsh.option.setNumber("General.Terminal", 0)
        return gmsh

    def __exit__(self, *exc: Any) -> None:
        import gmsh

        global _gmsh_started_here
        if self.owner:
            gmsh.finalize()
            _gmsh_started_here = False


def scatter_reverse_add(x: Any) -> None:
    """Sum the ghost entries of a dolfinx la.Vector onto their owners (ScatterMode in 0.5-0.6, InsertMode after)."""
    import dolfinx.la

    mode = getattr(dolfinx.la, "ScatterMode", None) or dolfinx.la.InsertMode  # pragma: no branch
    x.scatter_reverse(mode.add)
