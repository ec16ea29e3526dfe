"""Constraints: the Dirichlet conditions of a scene and which dofs SNES solves for.

Outer epidermis surface: u = 0. Axis: u_r = 0. Everything else is traction-free. The mixed
formulation pins the pressure unknowns that touch no tissue cell to 0, and a rigid suture is
u = (0, d) on every suture dof (the interface included), written as boundary conditions so that
everything that reads ``bcs`` sees which dofs are constrained.

What SNES solves for is ``T x`` (:class:`Unknowns`): every dof that is not fixed by a boundary
condition, except that with a rigid suture all of the suture's dofs are replaced by one axial motion d
and its equation is the axial force balance of the suture (the solver's reduction updates d).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import dolfinx
import dolfinx.fem
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.support import compat

#: Kinds of dof in :attr:`Unknowns.kind`: solved for, fixed at 0, moving with the rigid suture's d, or held to move
#: along the hoop direction only (a 3-D sliding thread's track: :attr:`Unknowns.hoop`).
FREE, FIXED, RIGID, HOOP = 0, 1, 2, 3


@dataclass
class Unknowns:
    """Which local dofs of the state SNES solves for: FREE ones, FIXED (= 0) ones, RIGID (= d) ones.

    ``kind`` covers owned and ghost dofs of the state's space (unrolled); with a rigid suture the
    axial dofs of every suture node are RIGID and its radial dofs FIXED.
    """

    kind: np.ndarray
    n_owned: int
    rigid: bool
    hoop: np.ndarray | None = None
    hoop_dirs: np.ndarray | None = None

    def count(self, comm: Any) -> int:
        """Global number of unknowns SNES solves for (free dofs, the hoop motions, plus d with a rigid suture)."""
        free = int(np.count_nonzero(self.kind[: self.n_owned] == FREE)) + self.count_hoop()
        return comm.allreduce(free) + (1 if self.rigid else 0)

    def count_hoop(self) -> int:
        """Local number of hoop motions (one unknown each, its node's owner's)."""
        return 0 if self.hoop is None else int(np.count_nonzero(self.hoop[:, 0] < self.n_owned))

    def hold_to_hoop(self, pairs: np.ndarray, dirs: np.ndarray) -> None:
        """Nodes that move along (t_x, t_z) only in the x-z plane: ``pairs`` their (u_x, u_z) dofs, ``dirs`` t.

        A node with a dof already held (a boundary condition, the rigid suture) keeps it: it is left out.
        """
        free = np.all(self.kind[pairs] == FREE, axis=1)
        self.hoop, self.hoop_dirs = pairs[free], dirs[free]
        self.kind[self.hoop.ravel()] = HOOP

    def count_rigid(self, comm: Any) -> int:
        """Global number of dofs replaced by the rigid suture's motion d."""
        return comm.allreduce(int(np.count_nonzero(self.kind[: self.n_owned] == RIGID)))


def classify_dofs(W: Any, bcs: list[Any], rigid_bc: Any = None) -> Unknowns:
    """Classify every local dof of W: FIXED by a (zero) boundary condition, RIGID or FREE.

    RIGID dofs are those of ``rigid_bc`` (u_z = d on the rigid suture), which is also in ``bcs``.
    """
    im = W.dofmap.index_map
    bs = W.dofmap.index_map_bs
    kind = np.full((im.size_local + im.num_ghosts) * bs, FREE, dtype=np.int8)
    for bc in bcs:
        kind[bc.dof_indices()[0]] = FIXED
    if rigid_bc is not None:
        kind[rigid_bc.dof_indices()[0]] = RIGID
    return Unknowns(kind=kind, n_owned=im.size_local * bs, rigid=rigid_bc is not None)


def mark_dofs(W: Any, cells: Any, sub: Any | None = None) -> Any:
    """Boolean mask over W's local dofs (owned and ghost): touched by any of the cells on any rank.

    ``sub`` restricts to a subspace of W (its dofmap indexes W). The marks are summed onto the owners
    and sent back to the ghosts, so a dof shared across ranks is marked everywhere.
    """
    space = W if sub is None else sub
    carrier = dolfinx.fem.Function(W)
    carrier.x.array[:] = 0.0
    if len(cells):
        dofs = compat.cell_dofs(space)[cells]
        bs = space.dofmap.bs
        if bs > 1:  # a blocked dofmap lists nodes: unroll
            dofs = (bs * dofs[:, :, None] + np.arange(bs)[None, None, :]).reshape(len(cells), -1)
        carrier.x.array[np.unique(dofs)] = 1.0
    compat.scatter_reverse_add(carrier.x)
    carrier.x.scatter_forward()
    return carrier.x.array > 0.5


def mark_facet_nodes(V: Any, fdim: int, facets: np.ndarray) -> np.ndarray:
    """Per local node of V: on any of the facets on any rank (an owned node's facets may all lie on another rank).

    The marks are summed onto the owners and sent back to the ghosts.
    """
    carrier = dolfinx.fem.Function(V)
    carrier.x.array[:] = 0.0
    blocks = np.asarray(dolfinx.fem.locate_dofs_topological(V, fdim, facets))
    bs = V.dofmap.index_map_bs
    carrier.x.array[(bs * blocks[:, None] + np.arange(bs)[None, :]).ravel()] = 1.0
    compat.scatter_reverse_add(carrier.x)
    carrier.x.scatter_forward()
    return carrier.x.array.reshape(-1, bs)[:, 0] > 0.5


def supports(tagged: meshmod.TaggedMesh, W_u: Any) -> tuple[list[Any], np.ndarray]:
    """The supports: u = 0 on the outer surface and a roller; and the outer surface's axial dofs.

    The roller is u_r = 0 on the axis of the axisymmetric section, or, for the 3-D half model
    (``geometry.dimension = 3``: the half of the cylinder on one side of the plane z = 0, which holds the
    thread's axis y), u_z = 0 on that symmetry plane, where the whole solid's symmetric solution has it.
    Conditions are set per component, so the same code serves the vector space and the mixed space's
    displacement subspace ``W_u``. Returns (bcs, outer axial dofs); the latter locate the reaction force.
    """
    mesh = tagged.mesh
    gdim = mesh.geometry.dim
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    outer = meshmod.facets(tagged, regions.Facet.OUTER)
    component, roller = (2, regions.Facet.SYMMETRY) if gdim == 3 else (0, regions.Facet.AXIS)
    zero = PETSc.ScalarType(0.0)

    def fixed(c: int, facets: np.ndarray) -> Any:
        return dolfinx.fem.dirichletbc(zero, dolfinx.fem.locate_dofs_topological(W_u.sub(c), fdim, facets), W_u.sub(c))

    bcs = [fixed(c, outer) for c in range(gdim)] + [fixed(component, meshmod.facets(tagged, roller))]
    outer_axial = dolfinx.fem.locate_dofs_topological(W_u.sub(1), fdim, outer)
    return bcs, np.asarray(outer_axial, dtype=np.int32)


def thread_track(tagged: meshmod.TaggedMesh, W_u: Any) -> tuple[Any, dict[str, int]]:
    """A sliding thread's track: u_r = 0 on the tissue's side of it (facets tagged ``track``).

    Returns the condition and its note for the record: ``track_nodes``, the nodes it holds. A mesh without the track
    (built without ``split_thread``) is an error: the thread would stay tied.
    """
    mesh = tagged.mesh
    fdim = mesh.topology.dim - 1
    track = meshmod.facets(tagged, regions.Facet.TRACK)
    if mesh.comm.allreduce(len(track)) == 0:
        raise ValueError('effects.thread_interface = "sliding" needs the mesh built with the thread\'s track split '
                         "(suture_fem.geometry.mesh.scene_mesh, or create_mesh(..., split_thread=True))")
    dofs = dolfinx.fem.locate_dofs_topological(W_u.sub(0), fdim, track)
    bc = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs, W_u.sub(0))
    _, owned = bc.dof_indices()  # the dofs, owned ones first, and how many are owned
    return bc, {"track_nodes": mesh.comm.allreduce(int(owned))}


def thread_track_3d(tagged: meshmod.TaggedMesh, W_u: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """A 3-D sliding thread's track: u . e_r = 0 at the tissue's nodes on it, e_r = (x, 0, z) / r off the axis y.

    Returns (the condition u_x = 0 at the track's nodes on the symmetry plane z = 0, where e_r is +-x and u_z is
    already 0; the other nodes' (u_x, u_z) dofs, one row each; their hoop directions t = (-z, x) / r). Each of
    the latter moves along y and t only (:meth:`Unknowns.hold_to_hoop`, the solver's reduction).
    """
    mesh = tagged.mesh
    fdim = mesh.topology.dim - 1
    track = meshmod.facets(tagged, regions.Facet.TRACK)
    xyz = []
    dofs = []
    for c in (0, 2):
        sub = W_u.sub(c)
        collapsed, to_parent = sub.collapse()
        # a Dirichlet condition's dofs: every rank's, an owned node's facets may all lie on another rank
        found = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dolfinx.fem.locate_dofs_topological(sub, fdim, track),
                                        sub).dof_indices()[0]
        to_parent = np.asarray(to_parent)
        inverse = np.full(max(int(to_parent.max()), int(np.max(found, initial=0))) + 1, -1, dtype=np.int64)
        inverse[to_parent] = np.arange(len(to_parent))
        order = np.argsort(inverse[found])  # by node: the collapsed components' dofs are numbered alike
        dofs.append(np.asarray(found, dtype=np.int32)[order])
        xyz.append(collapsed.tabulate_dof_coordinates()[inverse[found][order]])
    unpaired = len(dofs[0]) != len(dofs[1]) or not np.allclose(xyz[0], xyz[1], rtol=0.0, atol=1e-12)
    if mesh.comm.allreduce(unpaired, op=MPI.LOR):  # on every rank: one rank alone raising would hang the others
        raise RuntimeError("the track's u_x and u_z dofs do not pair node by node")
    x, z = xyz[0][:, 0], xyz[0][:, 2]
    r = np.hypot(x, z)
    on_plane = np.abs(z) <= 1e-9 * r
    bc = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs[0][on_plane], W_u.sub(0))
    pairs = np.stack([dofs[0][~on_plane], dofs[1][~on_plane]], axis=1)
    dirs = np.stack([-z[~on_plane], x[~on_plane]], axis=1) / r[~on_plane, None]
    return bc, pairs, dirs


def pinned_pressure(tagged: meshmod.TaggedMesh, W: Any) -> tuple[Any, dict[str, int]]:
    """Mixed formulation: pressure unknowns that touch no tissue cell have no equation, so pin them to 0.

    Returns the boundary condition and its counts (``pressure_dofs``, ``pressure_dofs_pinned_in_suture``)
    for the ``effects`` record.
    """
    mesh = tagged.mesh
    tissue_cells = meshmod.region_cells(tagged, regions.TISSUE)
    in_tissue = mark_dofs(W, tissue_cells, W.sub(1))
    cells = mesh.topology.index_map(mesh.topology.dim).size_local
    p_all = mark_dofs(W, np.arange(cells, dtype=np.int32), W.sub(1))
    pinned = np.flatnonzero(p_all & ~in_tissue).astype(np.int32)
    bc = dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), pinned, W.sub(1))
    owned = W.dofmap.index_map.size_local
    counts = {
        "pressure_dofs": mesh.comm.allreduce(int(np.count_nonzero(p_all[:owned]))),
        "pressure_dofs_pinned_in_suture": mesh.comm.allreduce(int(np.count_nonzero(pinned < owned))),
    }
    return bc, counts


@dataclass
class RigidConstraint:
    """The rigid suture as boundary conditions: u_r = 0 and u_z = d on every suture dof.

    Attributes:
        displacement: the Constant d (m), updated by the solver's reduction.
        radial: u_r = 0 on the suture's dofs (in 3-D: u_x = 0, and ``hoop``: u_z = 0, off the thread's axis y);
        axial: u_z = d on them (its dofs become RIGID).
    """

    displacement: Any
    radial: Any
    axial: Any
    hoop: Any = None

    @property
    def bcs(self) -> list[Any]:
        """The conditions, the axial one last."""
        return [self.radial, *([self.hoop] if self.hoop is not None else []), self.axial]


def rigid_suture(tagged: meshmod.TaggedMesh, W: Any, W_u: Any) -> RigidConstraint:
    """The rigid suture's constraint on every dof of a suture cell (the interface included)."""
    displacement = dolfinx.fem.Constant(tagged.mesh, PETSc.ScalarType(0.0))
    suture_cells = meshmod.region_cells(tagged, regions.SUTURE)
    dim = tagged.mesh.geometry.dim
    radial, axial, *hoop = (np.flatnonzero(mark_dofs(W, suture_cells, W_u.sub(c))).astype(np.int32)
                            for c in (0, 1, 2)[:dim])
    return RigidConstraint(
        displacement=displacement,
        radial=dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), radial, W_u.sub(0)),
        axial=dolfinx.fem.dirichletbc(displacement, axial, W_u.sub(1)),
        hoop=dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), hoop[0], W_u.sub(2)) if hoop else None,
    )
