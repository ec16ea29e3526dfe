"""The Krylov method's GAMG options on a stiff bar in a soft block (modulus ratio 1e6), against LU."""

from __future__ import annotations

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.solve import linear
from suture_fem.support import compat


def _stiff_bar_in_soft_block() -> tuple:
    """Linear elasticity on the unit cube, clamped at x = 0, a bar along x of modulus 1e6 in tissue of modulus 1."""
    mesh = dolfinx.mesh.create_unit_cube(MPI.COMM_WORLD, 8, 8, 8)
    V = compat.vector_space(mesh, 1)
    Q = compat.scalar_space(mesh, "DG", 0)
    modulus = dolfinx.fem.Function(Q)
    x = Q.tabulate_dof_coordinates()  # the cells' midpoints
    modulus.x.array[:] = np.where((abs(x[:, 1] - 0.5) < 0.13) & (abs(x[:, 2] - 0.5) < 0.13), 1e6, 1.0)
    nu = 0.45
    lam, mu = modulus * nu / ((1 + nu) * (1 - 2 * nu)), modulus / (2 * (1 + nu))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = ufl.sym(ufl.grad(u))
    a = ufl.inner(2 * mu * eps + lam * ufl.tr(eps) * ufl.Identity(3), ufl.sym(ufl.grad(v))) * ufl.dx
    f = dolfinx.fem.Constant(mesh, PETSc.ScalarType((0.0, 0.3, 1.0)))
    clamped = dolfinx.mesh.locate_entities_boundary(mesh, 2, lambda p: np.isclose(p[0], 0.0))
    bc = dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType),
                                 dolfinx.fem.locate_dofs_topological(V, 2, clamped), V)
    A = dolfinx.fem.petsc.assemble_matrix(compat.form(a), bcs=[bc])
    A.assemble()
    b = dolfinx.fem.petsc.assemble_vector(compat.form(ufl.inner(f, v) * ufl.dx))
    dolfinx.fem.petsc.apply_lifting(b, [compat.form(a)], bcs=[[bc]])
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    dolfinx.fem.petsc.set_bc(b, [bc])
    return V, A, b


def _solve(A, b, options: dict, prefix: str) -> tuple:
    opts = PETSc.Options()
    for key, value in options.items():
        opts[prefix + key] = value
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setFromOptions()
    x = A.createVecRight()
    ksp.solve(b, x)
    out = ksp.getConvergedReason(), ksp.getIterationNumber()
    ksp.destroy()
    for key in options:
        opts.delValue(prefix + key)
    return x, out


def test_gamg_converges_on_a_stiff_bar_in_soft_tissue_to_the_direct_solution():
    V, A, b = _stiff_bar_in_soft_block()
    identity = PETSc.Mat().createAIJ(size=A.getSizes(), nnz=1, comm=A.getComm())  # T = I: every dof an unknown
    lo, hi = identity.getOwnershipRange()
    for i in range(lo, hi):
        identity.setValue(i, i, 1.0)
    identity.assemble()
    linear.set_near_nullspace(A, identity, V)
    options = linear.krylov_options("gamg")
    assert options["pc_gamg_agg_nsmooths"] == 0 and options["ksp_rtol"] == linear.KRYLOV_RTOL
    x, (reason, its) = _solve(A, b, options, "test_krylov_")
    assert reason > 0 and its < linear.KRYLOV_MAX_IT, (reason, its)
    exact, (reason, _) = _solve(A, b, {"ksp_type": "preonly", "pc_type": "lu"}, "test_direct_")
    assert reason > 0
    r = b.duplicate()
    A.mult(x, r)
    r.axpy(-1.0, b)
    assert r.norm() <= 1.01 * linear.KRYLOV_RTOL * b.norm()
    exact.axpy(-1.0, x)
    assert exact.norm() <= 1e-6 * x.norm()
