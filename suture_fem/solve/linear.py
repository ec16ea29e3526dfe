"""The linear solver of each Newton step: a direct factorisation, or a Krylov method with algebraic multigrid.

``solver.linear_method``:

* ``"direct"``: ``solver.linear_solver``'s factorisation (MUMPS by default), as in every 2-D scene.
* ``"gamg"``: GMRES preconditioned by PETSc's aggregation multigrid (GAMG), given the elastic
  near-nullspace: the rigid-body modes of the displacement (3 translations and 3 rotations in 3-D; 2
  translations and 1 rotation in a 2-D plane), restricted to the unknowns SNES solves for (x = T^T r,
  :mod:`suture_fem.solve.reduction`). Plain (unsmoothed) aggregation and 4 Chebyshev-Jacobi sweeps per
  level (:func:`krylov_options` tells why).
* ``"hypre"``: GMRES preconditioned by hypre's BoomerAMG (Debian's PETSc has it).
* ``"auto"``: ``"gamg"`` for a 3-D scene with at least ``solver.iterative_from_dofs`` unknowns, else
  ``"direct"`` (every 2-D scene stays direct).

GMRES (restarted every :data:`KRYLOV_RESTART` iterations), not CG: the tangent of an iterate far from
equilibrium can be indefinite (the direct path shifts it, solve/inertia.py), and CG with GAMG's
Chebyshev smoothers then stops with an indefinite preconditioner (measured on the coarse 3-D scene: CG
failed at the 14th solve, GMRES took 55-145 iterations on every solve of the ramp). A Krylov solve that
fails is a linear-solver failure, and the stepping's fallback then switches to the direct solvers
(:meth:`~suture_fem.solve.newton.NewtonSolver.next_linear_solver`).
Everything here is PETSc's own options; nothing is hand-written but the rigid-body modes.
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import numpy as np
from petsc4py import PETSc

from suture_fem.support import compat

#: The Krylov solve's tolerance relative to the right-hand side: tight enough that Newton keeps its
#: quadratic convergence down to the residual tests of solver.rtol / atol.
KRYLOV_RTOL = 1e-10
#: GMRES' restart length (its memory: this many vectors of the unknowns).
KRYLOV_RESTART = 200
#: Krylov iterations before a linear solve counts as failed.
KRYLOV_MAX_IT = 2000


def method_of(options: Any, problem: Any, unknowns: int) -> str:
    """"direct", "gamg" or "hypre": ``solver.linear_method`` with "auto" resolved by dimension and size."""
    if not hasattr(options, "method_for"):  # a problem's own options without the key: direct
        return getattr(options, "linear_method", "direct")
    return options.method_for(problem.W.mesh.geometry.dim, unknowns)


def configure(options: Any, newton: Any, base: dict[str, Any]) -> str:
    """The Newton solver's linear method: its PETSc options into ``base`` and, for GAMG, the near-nullspace.

    Returns the name the solver records: ``newton.linear_solver`` (direct) or the Krylov method's.
    """
    method = method_of(options, newton.physics, newton.reduction.n_global)
    if method == "direct":
        return newton.linear_solver
    base.update(krylov_options(method))
    if method == "gamg":
        set_near_nullspace(newton.A, newton.reduction.T, newton.physics.W)
    return method


def krylov_options(method: str) -> dict[str, Any]:
    """The PETSc options of a Krylov method, "gamg" or "hypre" (under the solver's prefix).

    GAMG's aggregation is unsmoothed (``pc_gamg_agg_nsmooths = 0``): on the 3-D cylinder (stiff thread
    in soft tissue, 1 cone, 0.25 N) smoothed aggregation's GMRES iterations grew along the load ramp (55 to
    185 per solve at 31 k dofs; more than KRYLOV_MAX_IT at 66 k, where MUMPS took over), unsmoothed
    aggregation's did not (95 to 138 at 31 k, 132 to 194 at 66 k). 4 smoothing sweeps per level, not 2:
    the iterations stay under KRYLOV_RESTART there (2 sweeps: 127 to 234 at 31 k, 175 to 346 at 66 k) for
    about the same seconds. BoomerAMG (strong threshold 0.5) broke down on the first solve at 31 k.
    """
    out: dict[str, Any] = {"ksp_type": "gmres", "ksp_gmres_restart": KRYLOV_RESTART, "ksp_rtol": KRYLOV_RTOL,
                           "ksp_atol": 0.0, "ksp_max_it": KRYLOV_MAX_IT,
                           "ksp_norm_type": "unpreconditioned"}
    if method == "gamg":
        out.update({"pc_type": "gamg", "pc_gamg_type": "agg", "pc_gamg_agg_nsmooths": 0, "pc_gamg_threshold": 0.01,
                    "mg_levels_ksp_type": "chebyshev", "mg_levels_ksp_max_it": 4, "mg_levels_pc_type": "jacobi"})
    else:
        out.update({"pc_type": "hypre", "pc_hypre_type": "boomeramg", "pc_hypre_boomeramg_strong_threshold": 0.5})
    return out


def rigid_body_modes(space: Any) -> list[Any]:
    """The rigid-body modes of a 3-D vector space's displacement, as PETSc vectors of the space."""
    mesh = space.mesh
    gdim = mesh.geometry.dim
    x = space.tabulate_dof_coordinates()[:, :gdim]
    bs = space.dofmap.index_map_bs
    n_local = space.dofmap.index_map.size_local
    x = x[:n_local]
    fields: list[np.ndarray] = []
    for c in range(gdim):  # translations
        v = np.zeros((n_local, bs))
        v[:, c] = 1.0
        fields.append(v)
    for a, b in [(0, 1), (1, 2), (2, 0)]:  # rotations in the (a, b) plane: u_a = -x_b, u_b = x_a
        v = np.zeros((n_local, bs))
        v[:, a], v[:, b] = -x[:, b], x[:, a]
        fields.append(v)
    carrier = dolfinx.fem.Function(space)  # kept alive while its vector is duplicated (dolfinx 0.9 frees it with it)
    template = compat.function_vector(carrier)
    vectors = []
    for v in fields:
        vec = template.duplicate()
        vec.array[: n_local * bs] = v.reshape(-1)
        vectors.append(vec)
    return vectors


def set_near_nullspace(A: Any, T: Any, space: Any) -> None:
    """Give the reduced matrix A = T^T A_full T the rigid-body modes restricted to the unknowns (x = T^T r).

    Only for a plain 3-D displacement space: a mixed space's pressure has no rigid-body mode, and of the
    axisymmetric section's plane modes only the axial translation costs no energy (GAMG's default then).
    """
    if space.mesh.geometry.dim != 3 or space.dofmap.index_map_bs != 3:
        return
    reduced = []
    for full in rigid_body_modes(space):
        x = T.createVecRight()
        T.multTranspose(full, x)
        reduced.append(x)
        full.destroy()
    nullspace = PETSc.NullSpace().create(vectors=_orthonormal(reduced), comm=A.getComm())
    A.setNearNullSpace(nullspace)


def _orthonormal(vectors: list[Any]) -> list[Any]:
    """Gram-Schmidt (twice) on PETSc vectors, dropping any that vanish (a mode the constraints remove)."""
    out: list[Any] = []
    for v in vectors:
        for _ in range(2):
            for q in out:
                v.axpy(-v.dot(q), q)
        norm = v.norm()
        if norm > 1e-12:
            v.scale(1.0 / norm)
            out.append(v)
    return out


def factor_type(problem: Any, linear_solver: str) -> str:
    """"cholesky" (MUMPS LDL^T) where the Jacobian is symmetric and MUMPS factorises it, else "lu".

    Symmetric: a scene's static, plain displacement problem (the Hessian of an energy). Not: the mixed
    formulation (its pressure rows are (U'(J) - p)/K0, not a derivative of the same potential), inertia
    (stiffness-proportional damping), and problems without effects (the verification problems keep LU).
    Coulomb friction's terms, at a frozen slip bound, are symmetric (:mod:`~suture_fem.physics.effects.friction`).
    """
    effects = getattr(problem, "effects", None)
    if linear_solver != "mumps" or effects is None or effects.mixed or effects.inertia:
        return "lu"
    return "cholesky"
