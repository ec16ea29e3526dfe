"""Quadratic (curved) cells: their Jacobian, the cells that fold, and the straightening of those cells.

A quadratic triangle or tetrahedron maps the reference cell by the P2 Lagrange basis through its nodes (the
vertices, then one node per edge, in dolfinx's, i.e. basix's, order: :data:`EDGES`). Its Jacobian determinant is a
polynomial (quadratic on a triangle, cubic on a tetrahedron); where it changes sign the cell folds over and would
integrate with a wrong sign without any error (:func:`folded`). Curving the edges of a sliver whose vertices all lie
on one curved surface folds it (the coarse 3-D meshes have such cells on the thread);
:func:`straighten_folded_gmsh` puts the mid-edge nodes of such cells back on their chords (a straight cell is valid
where its vertices are) before the mesh leaves gmsh.
"""

from __future__ import annotations

import numpy as np

#: The edges of the reference triangle and tetrahedron in dolfinx's (basix's) order of the P2 mid-side nodes.
EDGES = {2: ((1, 2), (0, 2), (0, 1)), 3: ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))}
#: gmsh's element types of the 6-node triangle and the 10-node tetrahedron.
GMSH_TRIANGLE6, GMSH_TETRAHEDRON10 = 9, 11


#: Where a triangle's Jacobian (a quadratic) is sampled: its vertices and edge midpoints, then its centroid (last).
TRIANGLE_POINTS = ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5), (0.0, 0.5), (0.5, 0.0), (1 / 3, 1 / 3))


def _bernstein_cubic() -> tuple[list[tuple[float, ...]], np.ndarray]:
    """The tetrahedron's degree-3 lattice (20 points) and the matrix from a cubic's values there to its coefficients.

    The coefficients are those of the Bernstein (Bezier) basis of degree 3 in the barycentric coordinates.
    """
    from math import factorial

    def bernstein(a: tuple[int, ...], lam: tuple[float, ...]) -> float:
        return factorial(3) / np.prod([factorial(e) for e in a]) * np.prod([lam[m] ** a[m] for m in range(4)])

    alphas = [(3 - i - j - k, i, j, k) for i in range(4) for j in range(4 - i) for k in range(4 - i - j)]
    points = [(a[1] / 3, a[2] / 3, a[3] / 3) for a in alphas]
    basis = np.array([[bernstein(a, tuple(e / 3 for e in b)) for a in alphas] for b in alphas])
    return points, np.linalg.inv(basis)


_CUBIC_POINTS, _TO_BERNSTEIN = _bernstein_cubic()


def jacobian_dets(x: np.ndarray, points: list[tuple[float, ...]] | np.ndarray) -> np.ndarray:
    """det(dx/dxi) of quadratic cells (nodes ``x``: (cells, 6 or 10, dim), basix's order) at reference ``points``.

    Returns (points, cells).
    """
    dim = x.shape[2]
    dlam = [[-1.0] * dim] + [[float(i == k) for i in range(dim)] for k in range(dim)]  # d(lambda_k)/d(xi)
    dets = []
    for xi in points:
        lam = [1.0 - sum(xi), *xi]
        grads = [[(4 * lam[k] - 1) * dlam[k][d] for d in range(dim)] for k in range(dim + 1)]
        for a, b in EDGES[dim]:  # the mid-side node of edge (a, b): 4 lambda_a lambda_b
            grads.append([4 * (lam[a] * dlam[b][d] + lam[b] * dlam[a][d]) for d in range(dim)])
        dets.append(np.linalg.det(np.einsum("cnx,nd->cxd", x, np.array(grads))))
    return np.array(dets)


def folded(x: np.ndarray) -> np.ndarray:
    """Which quadratic cells (nodes ``x``: (cells, 6 or 10, dim)) have a Jacobian that changes sign or vanishes.

    A triangle: sampled at :data:`TRIANGLE_POINTS`. A tetrahedron: its cubic's Bernstein coefficients, which bound it
    (the convex-hull property: all of one sign, the Jacobian has that sign everywhere in the cell), so a fold
    between sample points is not missed; a cell with a coefficient of the other sign counts as folded even where
    the cubic itself may stay positive (it is distorted close to folding).
    """
    if x.shape[2] == 2:
        dets = jacobian_dets(x, TRIANGLE_POINTS)
        return np.any(dets * np.sign(dets[-1]) <= 0.0, axis=0)
    coefficients = _TO_BERNSTEIN @ jacobian_dets(x, _CUBIC_POINTS)  # (20, cells)
    sign = np.sign(np.sum(coefficients, axis=0))  # the sign of the cell's volume
    return np.any(coefficients * sign <= 0.0, axis=0)


def volumes(x: np.ndarray) -> np.ndarray:
    """The volumes of quadratic tetrahedra (nodes ``x``: (cells, 10, 3)), exactly: det J is a cubic in the cell."""
    from suture_fem.support import compat

    points, weights = compat.quadrature_rule("tetrahedron", 3)
    return np.abs(weights @ jacobian_dets(x, points))


#: gmsh's 10-node tetrahedron in basix's node order: gmsh numbers its mid-edge nodes by the edges (0, 1), (1, 2),
#: (0, 2), (0, 3), (2, 3), (1, 3) (gmsh's reference manual, "Node ordering"; tests/unit/test_curved_3d.py checks it
#: on a mesh gmsh made).
GMSH_TO_BASIX = (0, 1, 2, 3, 8, 9, 5, 7, 6, 4)


def straighten_folded_gmsh(rounds: int = 5) -> int:
    """Straighten the folded 10-node tetrahedra of the current gmsh model (after ``setOrder(2)``); their count.

    A folded cell's mid-edge nodes move to their chords' midpoints; a neighbour sharing such an edge gets that edge
    straight too, so the check repeats (at most ``rounds`` times) until no cell folds.
    """
    import gmsh

    mesh = gmsh.model.mesh
    straightened: set[int] = set()
    for _ in range(rounds):
        cells, nodes, x = _gmsh_tetrahedra()
        bad = np.flatnonzero(folded(x)) if len(cells) else []
        if len(bad) == 0:
            break
        for c in bad:
            straightened.add(int(cells[c]))
            for e, (a, b) in enumerate(EDGES[3]):
                mesh.setNode(int(nodes[c, 4 + e]), list((x[c, a] + x[c, b]) / 2), [])
    return len(straightened)


def _gmsh_tetrahedra() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The current gmsh model's 10-node tetrahedra: their tags, node tags (cells, 10) and coordinates (cells, 10, 3).

    The nodes in basix's order (:data:`GMSH_TO_BASIX`).
    """
    import gmsh

    cells, nodes = gmsh.model.mesh.getElementsByType(GMSH_TETRAHEDRON10)
    nodes = np.asarray(nodes, dtype=np.int64).reshape(-1, 10)[:, list(GMSH_TO_BASIX)]
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    where = np.full(int(np.max(tags)) + 1, -1, dtype=np.int64)
    where[np.asarray(tags, dtype=np.int64)] = np.arange(len(tags))
    return np.asarray(cells), nodes, np.asarray(xyz).reshape(-1, 3)[where[nodes]]
