"""Condensation onto the contact DOFs: the compliance C = G K^-1 G^T (dense, on rank 0).

Two routes, both on the factorization PETSc already has:
- "schur": MUMPS's Schur complement S = K_cc - K_ci K_ii^-1 K_ic on the contact DOFs c
  (MatFactorSetSchurIS / MatFactorCreateSchurComplement through ctypes, since petsc4py
  3.18 does not wrap them; the whole index set is given on rank 0), then
  C = G_c S^-1 G_c^T densely on rank 0. The run asks for the Schur set on its one
  factorization (`request_schur`, `attach_schur`), which then also serves every solve
  (app/condensation/schur_solver.py). `compliance_schur` is the older route with a
  separate factorization, kept for the benchmarks.
- "solve": X = K^-1 G^T by one solve per column with the existing factorization, then
  C = G X. Works with any PETSc solver; cost grows with the number of pairs.
Displacements are recovered as u = u0 + K^-1 (G^T lambda) with one more solve of the
stored factorization per load step (never a refactorization).
"""

from __future__ import annotations

import ctypes
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from app import hard_stop
from app.condensation.schur_solver import petsc_call, read_dense_symmetric, schur_lib
from app.errors import InputError, SolveError
from app.parallel import rank0_call

if TYPE_CHECKING:
    from app.assembly.solve import LinearSolver


def schur_complement(k: PETSc.Mat, dofs: np.ndarray) -> np.ndarray | None:
    """Dense Schur complement of K onto `dofs` (sorted global indices), on rank 0.

    Uses a separate MUMPS LU factorization with a Schur index set. Returns the
    (len(dofs), len(dofs)) array on rank 0 and None on the other ranks.
    """
    lib = schur_lib()
    comm = k.getComm()
    rank = comm.getRank()
    ksp = PETSc.KSP().create(comm=comm)
    ksp.setOptionsPrefix("schur_")
    ksp.setOperators(k)
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    ksp.setFromOptions()
    pc.setFactorSetUpSolverType()
    f = pc.getFactorMatrix()
    idx = dofs.astype(PETSc.IntType) if rank == 0 else np.zeros(0, dtype=PETSc.IntType)
    iset = PETSc.IS().createGeneral(idx, comm=comm)
    petsc_call(lib, "MatFactorSetSchurIS", ctypes.c_void_p(f.handle),
               ctypes.c_void_p(iset.handle))
    with hard_stop.armed():  # the factorization with the Schur complement: one C call
        ksp.setUp()
    s_handle = ctypes.c_void_p()
    status = ctypes.c_int()
    petsc_call(lib, "MatFactorCreateSchurComplement", ctypes.c_void_p(f.handle),
               ctypes.byref(s_handle), ctypes.byref(status))
    out = read_dense_symmetric(lib, s_handle, dofs.size) if rank == 0 else None
    lib.MatDestroy(ctypes.byref(s_handle))
    ksp.destroy()
    iset.destroy()
    return out


def contact_dofs(g: sp.csr_matrix, fixed: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
    """Free DOFs touched by G, and G with the columns of prescribed DOFs removed.

    Returns (dofs (n_c,), G_c (2m, n_c)) where G u = G_c u[dofs] for any u that is zero
    on the prescribed DOFs.
    """
    g = g.tocsc()
    g.eliminate_zeros()
    keep = np.ones(g.shape[1], dtype=bool)
    keep[fixed] = False
    touched = np.flatnonzero((np.diff(g.indptr) > 0) & keep)
    return touched, g[:, touched].tocsr()


def compliance_schur(k: PETSc.Mat, g: sp.csr_matrix, fixed: np.ndarray) -> np.ndarray | None:
    """C = G K^-1 G^T through the Schur complement; dense (2m, 2m) on rank 0."""
    dofs, gc = contact_dofs(g, fixed)
    s = schur_complement(k, dofs)
    if s is None:
        return None
    try:
        from scipy.linalg import cho_factor, cho_solve

        fac = cho_factor(s)
        y = cho_solve(fac, gc.T.toarray())
    except np.linalg.LinAlgError:
        y = np.linalg.solve(s, gc.T.toarray())
    c = gc @ y
    return 0.5 * (c + c.T)


def request_schur(solver: LinearSolver, g: sp.csr_matrix, fixed: np.ndarray) -> np.ndarray:
    """Before `solver.factor()`: ask its MUMPS LU for the Schur set of the contact DOFs.

    Returns those DOFs (sorted global indices)."""
    from app.condensation.schur_solver import set_schur_dofs

    dofs, _ = contact_dofs(g, fixed)
    if dofs.size:  # no free contact DOF: a plain factorization, and C = 0
        set_schur_dofs(solver.ksp.getPC(), dofs)
    return dofs


def attach_schur(solver: LinearSolver, k: PETSc.Mat, dofs: np.ndarray) -> None:
    """After `solver.factor()`: take S from the factor, factorize it densely on rank 0, and
    route every later `solver.solve` through the block elimination on that factor."""
    from app.condensation.schur_solver import SchurFactorization

    if dofs.size:
        solver.block = SchurFactorization(k, solver.ksp.getPC().getFactorMatrix(), dofs)


def compliance_from_factor(solver: LinearSolver, g: sp.csr_matrix, fixed: np.ndarray,
                           pairs_first: np.ndarray | None = None) -> np.ndarray | None:
    """C = G_c S^-1 G_c^T with the S of `attach_schur`; dense (2m, 2m) on rank 0.
    pairs_first: pair indices, the likeliest to carry a force first (their columns of
    S^-1 G_c^T are kept for the steps' recoveries); None: pair order."""
    dofs, gc = contact_dofs(g, fixed)
    block = solver.block
    if not dofs.size:
        return np.zeros((g.shape[0], g.shape[0])) if k_rank(solver) == 0 else None
    if not np.array_equal(dofs, block.dofs):
        raise SolveError("the Schur set of the factorization is not the contact DOFs")
    return rank0_call(dense_compliance, gc, block, g.shape[0], pairs_first,
                      share_result=False)  # failure shared


def dense_compliance(gc: sp.csr_matrix, block, n_rows: int,
                     pairs_first: np.ndarray | None) -> np.ndarray:
    """Rank 0: G_c S^-1 G_c^T (symmetric, formed blockwise) with the dense factor of S in
    `block`; keeps the columns of S^-1 G_c^T that the recoveries will need (block.columns),
    those of `pairs_first` (default: the first half of the rows) first."""
    from app.condensation.compliance_product import compliance_product
    from app.condensation.contact_columns import ContactColumns

    # block.factor.solve, not block.dense_solve: a cycle through the block would leave its
    # MUMPS factor to the garbage collector on rank 0 alone (a collective destroy: a hang)
    columns = block.columns = ContactColumns(gc, block.factor.solve)  # the recoveries
    first = np.arange(n_rows // 2) if pairs_first is None else pairs_first
    return compliance_product(gc, lambda b: block.dense_solve(b, overwrite=True),
                              keep=lambda y: columns.prefill(y, first))


def k_rank(solver: LinearSolver) -> int:
    """The MPI rank of this process on the stiffness's communicator."""
    return solver.k.getComm().getRank()


def compliance_solve(solver: LinearSolver, k: PETSc.Mat, g: sp.csr_matrix, fixed: np.ndarray,
                     to_numpy_all: Callable[[PETSc.Vec], np.ndarray]) -> np.ndarray | None:
    """C = G K^-1 G^T by one solve per row of G with the stored factorization. Each
    column's residual is judged against the largest column of G^T (a unit pair force):
    a row of G that is round-off (|G^T e_j| = 1.5e-16 on patch.toml at --mesh-size 1.0)
    is solved by -ksp_atol 1e-12 as x = 0, which is right."""
    dofs, gc = contact_dofs(g, fixed)
    rank = k.getComm().getRank()
    r0, r1 = k.getOwnershipRange()
    ncols = g.shape[0]
    c = rank0_call(np.zeros, (ncols, ncols), share_result=False)  # its MemoryError shared
    b = k.createVecLeft()
    gt = gc.T.tocsc()
    unit = float(np.sqrt(np.asarray(gt.multiply(gt).sum(axis=0))).max(initial=0.0))
    with hard_stop.armed():  # once for all the solves (each one C call)
        for j in range(ncols):
            col = np.zeros(k.getSize()[0])
            lo, hi = gt.indptr[j], gt.indptr[j + 1]
            col[dofs[gt.indices[lo:hi]]] = gt.data[lo:hi]
            b.setArray(col[r0:r1])
            x = to_numpy_all(solver.solve(b, scale=unit))
            if rank == 0:
                c[:, j] = gc @ x[dofs]
    return rank0_call(symmetric_part, c, share_result=False)


def symmetric_part(c: np.ndarray) -> np.ndarray:
    """(C + C^T) / 2 of a dense compliance (rank 0)."""
    return 0.5 * (c + c.T)


COMPLIANCE_ROUTES = ("auto", "schur", "solve")


def compliance_route(configured: str, solver: LinearSolver) -> str:
    """The route of C = G K^-1 G^T: the option -contact_compliance, else `configured`
    (analysis.compliance); auto is schur with MUMPS LU and solve otherwise."""
    route = PETSc.Options().getString("contact_compliance", configured)
    if route not in COMPLIANCE_ROUTES:
        raise InputError(f"compliance route '{route}': use auto, schur or solve")
    if route == "auto":
        route = "schur" if solver.is_mumps_lu else "solve"
    if route == "schur" and not solver.is_mumps_lu:
        raise InputError("the schur compliance route needs MUMPS LU: use "
                         "-contact_compliance solve with other solvers")
    return route
