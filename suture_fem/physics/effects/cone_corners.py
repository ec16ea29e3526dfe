"""The cones' corners against the tissue's facets: the second pass of the cones' contact (2-D, unilateral cones).

The cones' contact (:mod:`.cone_contact`) keeps the tissue's nodes out of the cones. A cone's convex corner can
still pass between two of them: tissue sliding round the corner stretches the facet between its nodes over it,
and the corner cuts through that facet into the tissue, with every node outside (docs/contact.md, "The apex-cap
stall"). This pass is the other side's search: each corner of a cone (the midpoint of each convex arc of its
search outline, :func:`~suture_fem.geometry.outline.convex_corners`: the search's rounded corners and the real
fillets) is projected onto the tissue's facets on that cone (their chain of straight pieces; a P2 facet by its
two halves), relative to the cone (the facets' nodes moved back by the cone's axial shift t_c). Its signed
distance d is positive on the cone's side of the chain: the nearest piece's outward normal beside it, the mean
of its two pieces' normals at a node. With w the corner's ring area (2 pi r h, h the suture's element size) and
kappa the cones' penalty, the potential is the cones' own augmented Lagrangian in d,

    sum_k (<lambda_k - kappa d_k>^2 - lambda_k^2) / (2 kappa),   d measured from min(d at rest, 0),

so a corner presses the facet's nodes into the tissue (by the piece's linear weights) and the cone back along
the normal. At rest the search's rounded corners lie inside the cone (0.41 of their radius at a right angle)
and press nothing; a real fillet's midpoint may lie past its facets' chord, and is measured from there. The
Jacobian is kappa w g g^T where pressed, g = dd/d(dofs) (-(1 - xi) n and -xi n on the piece's ends, n_z / n_b on
each of the cone's n_b axial dofs), less w p d2d: exact beside a piece (its normal's turning); off a node the
distance's bending is kept only inside the tissue, not within BENDING_FLOOR of the node. The multipliers move with
the cones' (:meth:`~.cone_contact.ConeContact.update`, plain Uzawa) to the same target.

``effects.cone_corners = "measured"`` (the default) only reports the corners (:meth:`CornerPass.status`); "held"
adds their terms. Every rank searches every corner against the whole chain (a few hundred pieces, gathered once);
rank 0 adds the terms. Not in 3-D (the unilateral cones are 2-D only) nor for the bilateral sliding cones.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from petsc4py import PETSc

from suture_fem.geometry import regions
from suture_fem.geometry.mesh import facets as tagged_facets
from suture_fem.geometry.outline import convex_corners
from suture_fem.geometry.regions import Facet
from suture_fem.physics.effects.cone_pairs import nearest_cone
from suture_fem.physics.effects.friction import global_dofs
from suture_fem.support import compat


def chain(physics: Any, outlines: list) -> dict[str, np.ndarray]:
    """The tissue's facets on the cones as straight pieces, every rank's (collective).

    ``nodes``: (V, 2) the pieces' ends' global dofs (u_r, u_z); ``X``: (V, 2) their reference places (mm);
    ``pieces``: (S, 2) indices into them, oriented with the tissue on the left; ``cone``: (S,) the nearest cone.
    """
    mesh, V = physics.mesh, physics.V
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    to_cell, to_facet = mesh.topology.connectivity(tdim - 1, tdim), mesh.topology.connectivity(tdim, tdim - 1)
    cells, owned = compat.cell_dofs(V), mesh.topology.index_map(tdim).size_local
    xy = V.tabulate_dof_coordinates()[:, :2] / regions.MM
    ends = []
    for f in tagged_facets(physics.tagged, Facet.CONE_CONTACT):
        cell = int(to_cell.links(f)[0])
        if cell >= owned:  # the owning rank of its cell lists it
            continue
        i = int(np.flatnonzero(to_facet.links(cell) == f)[0])  # the cell's local facet i: opposite its vertex i
        a, b = (cells[cell][j] for j in range(3) if j != i)
        edge, off = xy[b] - xy[a], xy[cells[cell][i]] - xy[a]
        if edge[0] * off[1] - edge[1] * off[0] < 0.0:
            a, b = b, a  # the tissue (the opposite vertex) on the left of a -> b
        if len(cells[cell]) > 3:  # P2: the edge's middle node (edge i opposite vertex i), on an arc if cells are curved
            ends += [(a, cells[cell][3 + i]), (cells[cell][3 + i], b)]
        else:
            ends.append((a, b))
    local = np.array(ends, dtype=np.int64).reshape(-1, 2)
    dofs = np.stack([global_dofs(physics, local.ravel(), c) for c in range(2)], axis=1).reshape(-1, 2, 2)
    dofs = np.concatenate(physics.comm.allgather(dofs))
    places = np.concatenate(physics.comm.allgather(xy[local.ravel()].reshape(-1, 2, 2)))
    nodes, index = np.unique(dofs.reshape(-1, 2), axis=0, return_inverse=True)
    X = np.zeros((len(nodes), 2))
    X[index.ravel()] = places.reshape(-1, 2)
    pieces = index.reshape(-1, 2)
    cone = nearest_cone(0.5 * (X[pieces[:, 0]] + X[pieces[:, 1]]), outlines)
    return {"nodes": nodes, "X": X, "pieces": pieces, "cone": cone}


#: The distance's bending off a node, (I - n n^T) / d, is left out of the Jacobian within this fraction of the
#: piece's length of the node: it grows without bound as a held corner comes to rest on the node.
BENDING_FLOOR = 0.05


class CornerPass:
    """The cones' corners against the tissue's facets (see the module docstring); every rank holds them all."""

    def __init__(self, comm: Any, state: Any, pieces: dict[str, np.ndarray], outlines: list,
                 cone_dofs: list[np.ndarray], kappa: float, h_m: float):
        """``pieces``: :func:`chain`'s; ``cone_dofs``: per cone, its axial dofs; ``h_m``: the suture's element size."""
        self.comm, self.kappa, self.cone_dofs = comm, float(kappa), cone_dofs
        self.nodes, self.X, self.pieces = pieces["nodes"], pieces["X"], pieces["pieces"]
        self.piece_cone = pieces["cone"]
        found = [(c, p) for c, o in enumerate(outlines) for p in convex_corners(o)]
        self.cone = np.array([c for c, _ in found], dtype=np.int64)
        self.C = np.array([p for _, p in found], dtype=float).reshape(-1, 2)
        self.weight = 2.0 * math.pi * self.C[:, 0] * regions.MM * float(h_m)
        self.count = len(self.cone)
        self.multiplier = np.zeros(self.count)
        self._local = PETSc.Vec().createSeq(self.nodes.size, comm=PETSc.COMM_SELF)
        index = PETSc.IS().createGeneral(self.nodes.ravel().astype(PETSc.IntType), comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(state, index, self._local, None)
        index.destroy()
        self.d0 = np.zeros(self.count)
        self._found: tuple[np.ndarray, dict[str, np.ndarray]] | None = None
        rest = self._search(np.zeros(self.nodes.size), np.zeros(len(outlines)))
        self.d0 = np.minimum(rest["d"], 0.0)  # a fillet's midpoint past its chord at rest: measured from there

    def _search(self, u: np.ndarray, t_c: np.ndarray) -> dict[str, np.ndarray]:
        """Each corner's nearest piece, its parameter xi, signed distance d (m) and normal n."""
        x = self.X + u.reshape(-1, 2) / regions.MM  # the pieces' ends now (mm)
        a, b = self.pieces[:, 0], self.pieces[:, 1]
        shift = np.zeros((len(a), 2))
        shift[:, 1] = t_c[self.piece_cone] / regions.MM if len(t_c) else 0.0
        pa, pb = x[a] - shift, x[b] - shift  # relative to each piece's cone: moved back by its axial shift
        edge = pb - pa
        length = np.maximum(np.linalg.norm(edge, axis=1), 1e-150)  # its square stays above 0
        normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1) / length[:, None]  # the tissue on the left: outward
        at_node = np.zeros_like(x)
        np.add.at(at_node, a, normal)
        np.add.at(at_node, b, normal)
        at_node /= np.maximum(np.linalg.norm(at_node, axis=1), 1e-300)[:, None]
        rel = self.C[:, None, :] - pa[None, :, :]  # (corners, pieces, 2)
        xi = np.clip(np.einsum("kpi,pi->kp", rel, edge) / (length**2)[None, :], 0.0, 1.0)
        gap = rel - xi[:, :, None] * edge[None, :, :]
        dist = np.where(self.piece_cone[None, :] == self.cone[:, None], np.linalg.norm(gap, axis=2), np.inf)
        best = np.argmin(dist, axis=1) if self.count and len(a) else np.zeros(self.count, dtype=np.int64)
        k = np.arange(self.count)
        xi_k, gap_k, dist_k = xi[k, best], gap[k, best], dist[k, best]
        side = np.where((xi_k <= 0.0)[:, None], at_node[a[best]], np.where((xi_k >= 1.0)[:, None], at_node[b[best]],
                                                                             normal[best]))
        sign = np.where(np.einsum("ki,ki->k", gap_k, side) < 0.0, -1.0, 1.0)  # inside the tissue: -
        sign[~np.isfinite(dist_k)] = 1.0  # a cone with no facets: never inside
        far = dist_k > 1e-12
        n = np.where(far[:, None], sign[:, None] * gap_k / np.where(far, dist_k, 1.0)[:, None], side)  # dd/dc
        interior = (xi_k > 0.0) & (xi_k < 1.0)
        tissue = self.X[a[best]] + xi_k[:, None] * (self.X[b[best]] - self.X[a[best]])  # its reference place (mm)
        return {"piece": best, "xi": xi_k, "d": sign * dist_k * regions.MM - self.d0, "n": n, "interior": interior,
                "rest_place": tissue,
                "t": edge[best] / length[best][:, None], "length": length[best] * regions.MM,
                "dist": sign * dist_k * regions.MM}

    def search(self, u_vec: Any, t_c: np.ndarray) -> dict[str, np.ndarray]:
        """:meth:`_search` at the state ``u_vec`` (collective), kept for the same state."""
        self._scatter.scatter(u_vec, self._local, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        values = np.concatenate([self._local.getArray(readonly=True), t_c])
        if self._found is None or not np.array_equal(values, self._found[0]):
            self._found = (values.copy(), self._search(values[: self.nodes.size], np.asarray(t_c)))
        return self._found[1]

    def _pressure(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        trial = self.multiplier - self.kappa * d
        return np.maximum(trial, 0.0), trial > 0.0

    def potential(self, u_vec: Any, t_c: np.ndarray) -> float:
        """The corners' potential (J), the same on every rank."""
        p, _ = self._pressure(self.search(u_vec, t_c)["d"])
        return float(np.sum(0.5 * self.weight * (p**2 - self.multiplier**2) / self.kappa))

    def _terms(self, found: dict[str, np.ndarray], k: int) -> tuple[np.ndarray, np.ndarray]:
        """Corner k's dofs and dd/d(dofs): the piece's two ends (u_r, u_z each), then its cone's axial dofs."""
        a, b = self.pieces[found["piece"][k]]
        xi, n = found["xi"][k], found["n"][k]
        cone = self.cone_dofs[self.cone[k]]
        dofs = np.concatenate([self.nodes[a], self.nodes[b], cone])
        grad = np.concatenate([-(1.0 - xi) * n, -xi * n, np.full(len(cone), n[1] / max(len(cone), 1))])
        return dofs, grad

    def add_residual(self, u_vec: Any, t_c: np.ndarray, b: Any) -> None:
        """Add dE/d(dofs) to the full residual ``b`` (rank 0 adds; not assembled here)."""
        found = self.search(u_vec, t_c)
        p, closed = self._pressure(found["d"])
        for k in np.flatnonzero(closed) if self.comm.rank == 0 else []:
            dofs, grad = self._terms(found, k)
            b.setValues(dofs.astype(PETSc.IntType), -self.weight[k] * p[k] * grad, addv=PETSc.InsertMode.ADD_VALUES)

    def add_jacobian(self, u_vec: Any, t_c: np.ndarray, A: Any) -> None:
        """Add each pressed corner's kappa w g g^T - w p T^T d2d T to ``A`` (rank 0 adds; not assembled here)."""
        found = self.search(u_vec, t_c)
        p, closed = self._pressure(found["d"])
        for k in np.flatnonzero(closed) if self.comm.rank == 0 else []:
            dofs, grad = self._terms(found, k)
            T = np.zeros((6, len(dofs)))  # (a, b, c) places from the dofs: a, b their own, c_z the cone's mean
            T[:4, :4] = np.eye(4)
            T[5, 4:] = 1.0 / max(len(dofs) - 4, 1)
            bend = T.T @ self._curvature(found, k) @ T
            index = dofs.astype(PETSc.IntType)
            A.setValues(index, index, self.weight[k] * (self.kappa * np.outer(grad, grad) - p[k] * bend),
                        addv=PETSc.InsertMode.ADD_VALUES)

    @staticmethod
    def _curvature(found: dict[str, np.ndarray], k: int) -> np.ndarray:
        """d2d / d(a, b, c)^2 (6 x 6, 1/m) of corner k: beside its piece, the piece's normal turning.

        Off the piece's end node, the distance's bending, kept only inside the tissue (where it stiffens: outside it
        softens) and deeper than BENDING_FLOOR of the piece (it grows as 1 / d at the node).
        """
        n, t, xi = found["n"][k], found["t"][k], found["xi"][k]
        out = np.zeros((6, 6))
        if found["interior"][k]:
            length, bent = found["length"][k], found["dist"][k] / found["length"][k]
            S, P, tn = np.outer(n, t) + np.outer(t, n), np.outer(n, n), np.outer(t, n)
            blocks = {(0, 0): -(1.0 - xi) * S - bent * P, (1, 1): xi * S - bent * P, (0, 1): -xi * S + bent * P + tn,
                      (0, 2): tn.T, (1, 2): -tn.T}
            for (i, j), block in blocks.items():
                out[2 * i: 2 * i + 2, 2 * j: 2 * j + 2] = block / length
                if i != j:
                    out[2 * j: 2 * j + 2, 2 * i: 2 * i + 2] = block.T / length
        elif found["dist"][k] < -BENDING_FLOOR * found["length"][k]:
            node = 0 if xi <= 0.0 else 2  # the piece's end nearest
            bend = (np.eye(2) - np.outer(n, n)) / found["dist"][k]
            for i, j, sign in ((node, node, 1.0), (4, 4, 1.0), (node, 4, -1.0), (4, node, -1.0)):
                out[i: i + 2, j: j + 2] = sign * bend
        return out

    def entries(self) -> tuple[np.ndarray, np.ndarray]:
        """(rows, cols) every corner may add, whatever piece it meets (rank 0's; for the pattern's widening)."""
        rows, cols = [], []
        for piece, c in zip(self.pieces, self.piece_cone) if self.comm.rank == 0 else []:
            if not np.any(self.cone == c):
                continue
            dofs = np.concatenate([self.nodes[piece[0]], self.nodes[piece[1]], self.cone_dofs[c]])
            rows.append(np.repeat(dofs, len(dofs)))
            cols.append(np.tile(dofs, len(dofs)))
        empty = np.zeros(0, dtype=np.int64)
        return np.concatenate(rows or [empty]), np.concatenate(cols or [empty])

    def worst(self, u_vec: Any, t_c: np.ndarray) -> float:
        """The farthest pressed corner off the facets, either side (m)."""
        d = self.search(u_vec, t_c)["d"]
        return float(np.max(np.where(self._pressure(d)[1], np.abs(d), 0.0), initial=0.0))

    def move(self, u_vec: Any, t_c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The multipliers moved to the pressure (Uzawa); rank 0's w (p - lambda), w delta lambda, w lambda (N)."""
        p, _ = self._pressure(self.search(u_vec, t_c)["d"])
        old, self.multiplier = self.multiplier, p.copy()
        parts = (self.weight * (p - old), self.weight * (p - old), self.weight * p)
        return tuple(v if self.comm.rank == 0 else v[:0] for v in parts)

    def status(self, u_vec: Any, t_c: np.ndarray) -> dict[str, Any]:
        """How many corners lie inside the tissue (past its facets), and how deep the deepest lies (mm)."""
        inside = int(np.count_nonzero(self.search(u_vec, t_c)["d"] < 0.0))
        return {"corners_inside_tissue": inside, "corner_penetration_max_mm": max(self.depths(u_vec, t_c), default=0.0)}

    def cut(self, u_vec: Any, t_c: np.ndarray, depth_mm: float) -> list[tuple[int, float, np.ndarray]]:
        """Each corner deeper than ``depth_mm`` inside the tissue: its cone, depth (mm) and the tissue it cuts.

        That tissue's reference place (mm): the nearest point of the corner's facet, where that tissue was at rest.
        """
        found = self.search(u_vec, t_c)
        depth = -found["d"] / regions.MM
        return [(int(self.cone[k]), float(depth[k]), found["rest_place"][k]) for k in np.flatnonzero(depth > depth_mm)]

    def depths(self, u_vec: Any, t_c: np.ndarray) -> list[float]:
        """Per cone, how deep its deepest corner lies inside the tissue (mm; 0 with none inside)."""
        d = self.search(u_vec, t_c)["d"]
        return [float(np.max(-d[self.cone == c], initial=0.0)) / regions.MM for c in range(len(self.cone_dofs))]

    def destroy(self) -> None:
        """Free the scatter and its local vector."""
        self._scatter.destroy()
        self._local.destroy()

