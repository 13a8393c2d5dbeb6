"""One MUMPS factorization with a Schur set that serves the compliance and every solve.

K is ordered as interior DOFs i and contact DOFs c. MUMPS factorizes K_ii and returns the
dense Schur complement S = K_cc - K_ci K_ii^-1 K_ic on rank 0 (MatFactorSetSchurIS and
MatFactorCreateSchurComplement through ctypes; the whole index set on rank 0). S is
factorized densely on rank 0 once (Cholesky, LU if that fails). Then:

- the compliance is C = G_c S^-1 G_c^T (app/condensation/compliance.py);
- a full solve K u = b is block elimination with two interior solves:
  y = K_ii^-1 b_i,  u_c = S^-1 (b_c - K_ci y_i),  u_i = y_i - K_ii^-1 K_ic u_c;
  when b_i = 0 (the contact-force recovery b = G^T lambda) the first one is skipped.

An interior solve is a MUMPS solve with ICNTL(26) = 0, which solves K_ii x_i = b_i and
sets x_c = 0. PETSc 3.18 refuses a full-system MatSolve on a factor with a Schur set in
parallel, but not this one, so the route works on any number of ranks and no second,
plain factorization is needed.
"""

from __future__ import annotations

import ctypes

import numpy as np
import scipy.linalg as sla
from petsc4py import PETSc

from app.errors import SolveError
from app.parallel import rank0_call
from app.petsc_lib import PETSC_INT, load_petsc


def schur_lib() -> ctypes.CDLL:
    """The PETSc shared library (ctypes), for the MUMPS Schur calls petsc4py lacks."""
    lib = load_petsc()
    if lib is None:
        raise SolveError("cannot load the PETSc shared library for the Schur route: use "
                         "-contact_compliance solve")
    return lib


def petsc_call(lib: ctypes.CDLL, name: str, *args) -> None:
    """Call the PETSc C function `name` with `args`; SolveError naming it when it fails."""
    err = getattr(lib, name)(*args)
    if err:
        raise SolveError(f"{name} failed (PETSc error {err})")


def set_schur_dofs(pc: PETSc.PC, dofs: np.ndarray) -> PETSc.Mat:
    """Ask the (not yet set up) MUMPS LU of `pc` for a Schur complement onto `dofs`.

    dofs: sorted global indices, significant on rank 0. Returns the factor matrix.
    """
    pc.setFactorSetUpSolverType()
    f = pc.getFactorMatrix()
    comm = f.getComm()
    idx = dofs.astype(PETSc.IntType) if comm.getRank() == 0 else np.zeros(0, PETSc.IntType)
    iset = PETSc.IS().createGeneral(idx, comm=comm)
    try:
        petsc_call(schur_lib(), "MatFactorSetSchurIS", ctypes.c_void_p(f.handle),
                   ctypes.c_void_p(iset.handle))
    finally:
        iset.destroy()
    return f


def read_dense_symmetric(lib, s_handle: ctypes.c_void_p, n: int) -> np.ndarray:
    """(S + S^T) / 2 of a dense (n, n) PETSc matrix given by its handle, read in place."""
    m_, n_ = PETSC_INT(), PETSC_INT()
    lib.MatGetSize(s_handle, ctypes.byref(m_), ctypes.byref(n_))
    if (m_.value, n_.value) != (n, n):
        raise SolveError(f"Schur complement has size {m_.value}x{n_.value}, "
                         f"expected {n}x{n}")
    ptr = ctypes.POINTER(ctypes.c_double)()
    lda = PETSC_INT()
    lib.MatDenseGetLDA(s_handle, ctypes.byref(lda))
    lib.MatDenseGetArrayRead(s_handle, ctypes.byref(ptr))
    raw = np.ctypeslib.as_array(ptr, shape=(n, lda.value))[:, :n]  # S^T, a view
    out = np.empty((n, n))
    np.add(raw, raw.T, out=out)
    out *= 0.5
    lib.MatDenseRestoreArrayRead(s_handle, ctypes.byref(ptr))
    return out


def schur_from_factor(f: PETSc.Mat, n: int) -> np.ndarray | None:
    """The dense (n, n) Schur complement of a factorized MUMPS matrix, symmetrized, on
    rank 0 (None elsewhere). Reads PETSc's own copy in place (MatFactorGetSchurComplement,
    no duplicate), so the only new memory is the returned array."""
    lib = schur_lib()
    s_handle = ctypes.c_void_p()
    status = ctypes.c_int()
    petsc_call(lib, "MatFactorGetSchurComplement", ctypes.c_void_p(f.handle),
               ctypes.byref(s_handle), ctypes.byref(status))
    out = None
    try:
        if f.getComm().getRank() == 0:
            out = read_dense_symmetric(lib, s_handle, n)
    finally:
        lib.MatFactorRestoreSchurComplement(ctypes.c_void_p(f.handle), ctypes.byref(s_handle),
                                            status)
    return out


class DenseFactor:
    """Cholesky (or, if that fails, LU) factorization of a dense symmetric matrix.

    s: (n, n), overwritten by the factor when `overwrite`; `again` gives s anew for the
    LU fallback (a failed Cholesky has overwritten it)."""

    def __init__(self, s: np.ndarray, overwrite: bool = False, again=None):
        try:
            self.chol = sla.cho_factor(s, overwrite_a=overwrite, check_finite=False)
            self.lu = None
        except np.linalg.LinAlgError:
            self.chol = None
            if overwrite:
                s = again() if again is not None else None
                if s is None:
                    raise
            self.lu = sla.lu_factor(s, overwrite_a=overwrite, check_finite=False)

    def solve(self, b: np.ndarray, overwrite: bool = False) -> np.ndarray:
        """S^-1 b for b of shape (n,) or (n, k); b may be overwritten when `overwrite`
        (in place when it is in Fortran order)."""
        if self.chol is not None:
            return sla.cho_solve(self.chol, b, overwrite_b=overwrite, check_finite=False)
        return sla.lu_solve(self.lu, b, overwrite_b=overwrite, check_finite=False)


class SchurFactorization:
    """Block solves of K u = b on a MUMPS factor with a Schur set (see the module text).

    k: the (Dirichlet-eliminated) stiffness; f: its factor, already factorized with the
    Schur set `dofs` (sorted global indices, the same on every rank).
    """

    def __init__(self, k: PETSc.Mat, f: PETSc.Mat, dofs: np.ndarray):
        self.k, self.f = k, f
        self.dofs = np.asarray(dofs, dtype=np.int64)
        comm = k.getComm()
        self.rank = comm.getRank()
        n = self.dofs.size
        s = schur_from_factor(f, n)
        self.factor = rank0_call(DenseFactor, s, share_result=False, overwrite=True,
                                 again=lambda: schur_from_factor(f, n))  # failure shared
        f.setMumpsIcntl(26, 0)  # interior solves from now on
        r0, r1 = k.getOwnershipRange()
        self.r0 = r0
        mine = self.dofs[(self.dofs >= r0) & (self.dofs < r1)]
        self.local_c = (mine - r0).astype(np.int64)
        self.interior = np.ones(r1 - r0, dtype=bool)
        self.interior[self.local_c] = False
        self.work = k.createVecLeft()
        self.seq = PETSc.Vec().createSeq(self.dofs.size if self.rank == 0 else 0,
                                         comm=PETSc.COMM_SELF)
        idx = self.dofs if self.rank == 0 else np.zeros(0, np.int64)
        iset = PETSc.IS().createGeneral(idx.astype(PETSc.IntType), comm=comm)
        self.to_zero = PETSc.Scatter().create(self.work, iset, self.seq, None)
        iset.destroy()
        self.columns = None  # rank 0's ContactColumns, set with the compliance

    def dense_solve(self, b: np.ndarray, overwrite: bool = False) -> np.ndarray:
        """S^-1 b on rank 0 (b: (n_c,) or (n_c, k); overwritten when `overwrite`)."""
        return self.factor.solve(b, overwrite)

    def _gather_c(self, v: PETSc.Vec) -> np.ndarray | None:
        """The contact entries of v on rank 0 (None elsewhere)."""
        self.to_zero.scatter(v, self.seq, addv=PETSc.InsertMode.INSERT,
                             mode=PETSc.ScatterMode.FORWARD)
        return self.seq.getArray().copy() if self.rank == 0 else None

    def _scatter_c(self, values: np.ndarray | None, v: PETSc.Vec) -> None:
        """v = 0 except v[dofs] = values (values significant on rank 0)."""
        v.set(0.0)
        if self.rank == 0:
            self.seq.setArray(values)
        self.to_zero.scatter(self.seq, v, addv=PETSc.InsertMode.INSERT,
                             mode=PETSc.ScatterMode.REVERSE)

    def interior_solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        """x_i = K_ii^-1 b_i, x_c = 0."""
        self.f.solve(b, x)
        x.getArray()[self.local_c] = 0.0

    def _contact_solve(self, bc: np.ndarray, forces: np.ndarray | None) -> np.ndarray:
        """Rank 0: u_c = S^-1 bc, from the kept columns when `forces` (bc = G_c^T forces)
        are given and the columns they need fit, else one solve with S."""
        uc = self.columns.apply(forces) if forces is not None and self.columns is not None \
            else None
        return self.dense_solve(bc) if uc is None else uc

    def solve(self, b: PETSc.Vec, x: PETSc.Vec, forces: np.ndarray | None = None
              ) -> PETSc.Vec:
        """x = K^-1 b by block elimination (two interior solves at most). forces: when b
        is G^T forces (no interior load; significant on rank 0), u_c comes from the kept
        columns S^-1 G_c^T (`self.columns`) instead of a solve with S."""
        comm = self.k.getComm().tompi4py()
        has_interior = comm.allreduce(bool(np.any(b.getArray(readonly=True)[self.interior])))
        y = self.k.createVecLeft()
        t = self.work
        bc = self._gather_c(b)
        if has_interior:
            self.interior_solve(b, y)
            self.k.mult(y, t)  # (K y)_c = K_ci y_i
            tc = self._gather_c(t)
            if self.rank == 0:
                bc -= tc
        # rank 0's part, its failure shared: the other ranks wait in the scatter below
        uc = rank0_call(self._contact_solve, bc, None if has_interior else forces,
                        share_result=False)
        w = self.k.createVecLeft()
        self._scatter_c(uc, w)  # w = u_c on c, 0 elsewhere
        self.k.mult(w, t)
        t.scale(-1.0)
        t.getArray()[self.local_c] = 0.0
        self.interior_solve(t, x)  # x_i = -K_ii^-1 K_ic u_c
        x.axpy(1.0, y)
        x.axpy(1.0, w)
        y.destroy()
        w.destroy()
        return x
