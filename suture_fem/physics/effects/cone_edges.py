"""Points between the nodes of the tissue's quadratic contact edges, kept out of the cones (P2 unilateral cones).

The cones' contact (:mod:`~suture_fem.physics.effects.cone_contact`) keeps the tissue's contact nodes out of
each cone. At P2 a contact edge of the tissue is a quadratic curve through two vertices and a midside node,
and with its three nodes outside the cone it can still bend into it, or a sharp rim of the cone can push
through it between two nodes (measured on one frictionless cone at 0.95-0.97 N: the cone's apex and base rims
inside tissue cells, an edge beside the apex rim 30 um inside the cone while its nodes are within 0.1 um).
Here each such edge is sampled at :data:`SAMPLES` points between its nodes, x(s) = sum_i N_i(s) x_i (the
edge's quadratic shape functions), and each sample point y = x(s) - t_c e_z is projected onto its cone's
search outline as the nodes are, with the pure penalty 1/2 kappa w <-phi>^2 (w: the edge's 2 pi r-weighted
length shared among its samples; phi measured from its reference value). Its gradient goes to the edge's
three nodes by N_i(s) and to the cone's axial dofs as the nodes' terms do; its Hessian couples the edge's
nodes (they share a cell, so the form's pattern holds them) and the cone's dofs (already in the cones'
pattern, every edge node being a contact node).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.outline import project
from suture_fem.geometry.regions import Facet
from suture_fem.physics.constraints import mark_dofs, mark_facet_nodes
from suture_fem.physics.effects.friction import global_dofs
from suture_fem.support import compat

#: The parameters of the sample points along an edge (0 and 1 its vertices, 1/2 its midside node).
SAMPLES = np.array([0.125, 0.25, 0.375, 0.625, 0.75, 0.875])
#: The samples' share of their edge's 2 pi r-weighted length (the nodes already carry all of it).
#: Measured at 1 and at 0.1 (docs/contact.md, "P2 cones"): neither carried one P2 cone as far as without.
SHARE = 1.0


def _shape(s: np.ndarray) -> np.ndarray:
    """(len(s), 3): the quadratic edge's N_a, N_b, N_m at s."""
    return np.stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)], axis=1)


def contact_edges(physics: Any, cone_of: Any) -> dict[str, np.ndarray]:
    """The tissue's quadratic contact edges whose midside node this rank owns: (E, 3) local nodes (a, b, m)."""
    V, mesh, tagged = physics.V, physics.mesh, physics.tagged
    fdim = mesh.topology.dim - 1
    n_local = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    owned = V.dofmap.index_map.size_local
    on = mark_facet_nodes(V, fdim, meshmod.facets(tagged, Facet.CONE_CONTACT))
    suture = mark_dofs(V, meshmod.region_cells(tagged, regions.SUTURE)).reshape(n_local, -1).any(axis=1)
    on &= ~suture
    xy = V.tabulate_dof_coordinates()[:, :2] / regions.MM
    cells = compat.cell_dofs(V)[meshmod.region_cells(tagged, regions.TISSUE)]
    found: dict[int, tuple[int, int, int]] = {}
    for c in cells:
        for i, j in ((1, 2), (0, 2), (0, 1)):
            a, b = int(c[i]), int(c[j])
            mids = c[3:]
            m = int(mids[np.argmin(np.linalg.norm(xy[mids] - 0.5 * (xy[a] + xy[b]), axis=1))])
            if on[a] and on[b] and on[m] and m < owned:
                found[m] = (a, b, m)
    nodes = np.array([found[m] for m in sorted(found)], dtype=np.int64).reshape(-1, 3)
    cone = cone_of(xy[nodes[:, 2]]) if len(nodes) else np.zeros(0, np.int64)
    keep = cone >= 0
    nodes, cone = nodes[keep], cone[keep]
    dofs = np.stack([global_dofs(physics, nodes.ravel(), 0), global_dofs(physics, nodes.ravel(), 1)], axis=1)
    length = np.linalg.norm(xy[nodes[:, 1]] - xy[nodes[:, 0]], axis=1) * regions.MM
    weight = 2 * math.pi * xy[nodes[:, 2], 0] * regions.MM * length * SHARE / len(SAMPLES)
    return {"nodes": nodes, "X": xy[nodes], "cone": cone, "dofs": dofs.reshape(-1, 3, 2), "weight": weight}


class EdgeSamples:
    """The sample points' penalty of the tissue's quadratic contact edges (see the module docstring)."""

    def __init__(self, state: Any, edges: dict[str, np.ndarray], outlines: list, cone_dofs: list[np.ndarray],
                 kappa: float, convexified: bool):
        self.kappa, self.convexified, self.outlines = float(kappa), convexified, outlines
        self.cone_dofs = [np.asarray(b, dtype=np.int64) for b in cone_dofs]
        self.edge_cone, self.dofs = edges["cone"], edges["dofs"]
        self.N = _shape(SAMPLES)  # (S, 3)
        S, E = len(SAMPLES), len(self.edge_cone)
        self.cone = np.repeat(self.edge_cone, S)
        self.weight = np.repeat(edges["weight"], S)
        self.X = np.einsum("sk,ekd->esd", self.N, edges["X"]).reshape(E * S, 2)  # mm
        self.phi0 = np.zeros(E * S)
        self._of_cone = [np.flatnonzero(self.cone == c) for c in range(len(outlines))]
        for sel, outline in zip(self._of_cone, outlines):
            self.phi0[sel] = project(self.X[sel], outline).distance
        index = PETSc.IS().createGeneral(self.dofs.ravel().astype(PETSc.IntType), comm=PETSc.COMM_SELF)
        self._local = PETSc.Vec().createSeq(self.dofs.size, comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(state, index, self._local, None)
        index.destroy()

    def _terms(self, u_vec: Any, t_c: np.ndarray) -> tuple[np.ndarray, ...]:
        """Per sample: (p (Pa), closed, n, curvature (1/m)) at the state ``u_vec``, cones moved by t_c (m)."""
        self._scatter.scatter(u_vec, self._local, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        u = self._local.getArray(readonly=True).reshape(-1, 3, 2)
        E, S = u.shape[0], len(SAMPLES)
        us = np.einsum("sk,ekd->esd", self.N, u).reshape(E * S, 2)
        y = self.X + (us - np.stack([np.zeros(E * S), t_c[self.cone]], axis=1)) / regions.MM
        phi, n, curvature = np.zeros(E * S), np.zeros((E * S, 2)), np.zeros(E * S)
        for sel, outline in zip(self._of_cone, self.outlines):
            proj = project(y[sel], outline)
            phi[sel] = (proj.distance - self.phi0[sel]) * regions.MM
            n[sel], curvature[sel] = proj.normal, proj.curvature / regions.MM
        p = np.maximum(-self.kappa * phi, 0.0)
        return p, p > 0.0, n, curvature

    def potential(self, u_vec: Any, t_c: np.ndarray) -> float:
        """This rank's part of sum 1/2 w p^2 / kappa (J)."""
        p = self._terms(u_vec, t_c)[0]
        return float(np.sum(0.5 * self.weight * p * p / self.kappa))

    def add_residual(self, u_vec: Any, t_c: np.ndarray, b: Any) -> None:
        """Add the gradient to ``b`` (not assembled here): nodes by N_i, the cones' axial dofs by -1 / n_b."""
        p, closed, n, _ = self._terms(u_vec, t_c)
        if not np.any(closed):
            return
        grad = (-(self.weight * p)[:, None] * n).reshape(-1, len(SAMPLES), 2)  # (E, S, 2)
        nodal = np.einsum("sk,esd->ekd", self.N, grad)  # (E, 3, 2)
        rows, values = [self.dofs.ravel()], [nodal.ravel()]
        for c, dofs in enumerate(self.cone_dofs):
            total = float(np.sum(nodal[self.edge_cone == c, :, 1]))
            if len(dofs) and total != 0.0:
                rows.append(dofs)
                values.append(np.full(len(dofs), -total / len(dofs)))
        b.setValues(np.concatenate(rows).astype(PETSc.IntType), np.concatenate(values),
                    addv=PETSc.InsertMode.ADD_VALUES)

    def add_jacobian(self, u_vec: Any, t_c: np.ndarray, A: Any) -> None:
        """Add the Hessian to ``A`` (not assembled here), edges with a pressed sample only."""
        p, closed, n, curvature = self._terms(u_vec, t_c)
        if not np.any(closed):
            return
        nn = n[:, :, None] * n[:, None, :]
        curvature = np.minimum(curvature, 0.0) if self.convexified else curvature
        H = (self.kappa * self.weight * closed)[:, None, None] * nn + (
            (-self.weight * p * curvature)[:, None, None] * (np.eye(2)[None] - nn))
        H = H.reshape(-1, len(SAMPLES), 2, 2)
        for e in np.flatnonzero(closed.reshape(-1, len(SAMPLES)).any(axis=1)):
            self._add_edge(A, e, H[e])

    def _add_edge(self, A: Any, e: int, H: np.ndarray) -> None:
        """One edge's blocks: K_ik = sum_s N_i N_k H_s, K_ib = -sum_s N_i H_s[:, z] / n_b, K_bb = sum H_zz / n_b^2."""
        block = np.einsum("si,sk,sde->idke", self.N, self.N, H).reshape(6, 6)
        rows = self.dofs[e].ravel().astype(PETSc.IntType)
        A.setValues(rows, rows, block, addv=PETSc.InsertMode.ADD_VALUES)
        b = self.cone_dofs[int(self.edge_cone[e])]
        if not len(b):
            return
        alpha = 1.0 / len(b)
        couple = -np.einsum("si,sd->id", self.N, H[:, :, 1]).reshape(6) * alpha
        cols = b.astype(PETSc.IntType)
        A.setValues(rows, cols, np.repeat(couple[:, None], len(b), axis=1), addv=PETSc.InsertMode.ADD_VALUES)
        A.setValues(cols, rows, np.repeat(couple[None, :], len(b), axis=0), addv=PETSc.InsertMode.ADD_VALUES)
        zz = float(np.sum(H[:, 1, 1])) * alpha * alpha
        A.setValues(cols, cols, np.full((len(b), len(b)), zz), addv=PETSc.InsertMode.ADD_VALUES)

    def destroy(self) -> None:
        """Free the scatter and its local vector."""
        self._scatter.destroy()
        self._local.destroy()
