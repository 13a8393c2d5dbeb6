"""A sparse symmetric positive definite matrix factorized on this rank alone.

MUMPS Cholesky on PETSc.COMM_SELF, for the shift-invert eigen-solve of one body's
zero-energy modes (`app.discretisation.bulk.zero_energy_modes`, its `factorize`): SciPy's
SuperLU with its minimum-degree orderings fills far more on large 2D meshes (a 67,813-DOF
body: 9.7 s with COLAMD, 2.1-2.8 s with MUMPS's nested-dissection-like ordering; at
17,317 DOFs 9.2 s with MMD_AT_PLUS_A, 0.3 s with MUMPS). The matrix and its solver carry
their own options prefix, so the user's PETSc options for the stiffness (-ksp_type,
-pc_type, -mat_mumps_icntl_*) do not reach it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

OPTIONS_PREFIX = "zero_modes_"
"""Options prefix of the matrix and its KSP: nobody sets -zero_modes_* options."""


class SequentialCholesky:
    """A factorized SPD matrix (n, n) on this rank: `solve(rhs)` gives A^-1 rhs, (n,)."""

    def __init__(self, matrix: sp.spmatrix) -> None:
        a = sp.csr_matrix(matrix)
        self._mat = PETSc.Mat().createAIJ(size=a.shape, comm=PETSc.COMM_SELF,
                                          csr=(a.indptr.astype(PETSc.IntType),
                                               a.indices.astype(PETSc.IntType), a.data))
        self._mat.setOptionsPrefix(OPTIONS_PREFIX)
        self._mat.setOption(PETSc.Mat.Option.SPD, True)
        self._ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        self._ksp.setOptionsPrefix(OPTIONS_PREFIX)
        self._ksp.setOperators(self._mat)
        self._ksp.setType("preonly")
        pc = self._ksp.getPC()
        pc.setType("cholesky")
        pc.setFactorSolverType("mumps")
        self._ksp.setUp()
        self._x, self._b = self._mat.createVecs()

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """A^-1 rhs for one right-hand side (n,)."""
        self._b.array[:] = rhs
        self._ksp.solve(self._b, self._x)
        return self._x.array.copy()

    def solve_block(self, rhs: np.ndarray) -> np.ndarray:
        """A^-1 rhs for a block of right-hand sides (n, p): one MUMPS solve of them all."""
        n, p = rhs.shape
        b = PETSc.Mat().createDense((n, p), array=np.asfortranarray(rhs, dtype=float),
                                    comm=PETSc.COMM_SELF)
        x = PETSc.Mat().createDense((n, p), comm=PETSc.COMM_SELF)
        x.setUp()
        try:
            self._ksp.getPC().getFactorMatrix().matSolve(b, x)
            return x.getDenseArray().copy()
        finally:
            b.destroy()
            x.destroy()

    def destroy(self) -> None:
        """Free the factor now (not at garbage collection)."""
        for obj in (self._ksp, self._mat, self._x, self._b):
            obj.destroy()
