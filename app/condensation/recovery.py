"""Displacements from contact forces with the stored factorization, and their
consistency with the compliance the LCP used."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

if TYPE_CHECKING:
    from app.assembly.solve import LinearSolver


def contact_displacement(g: sp.csr_matrix, lam: np.ndarray, solver: LinearSolver,
                         k: PETSc.Mat, fixed: np.ndarray,
                         to_numpy_all: Callable[[PETSc.Vec], np.ndarray],
                         scale: float | None = None) -> np.ndarray:
    """K^-1 G^T lambda (2n,) with the stored factorization (one solve, no refactorization);
    lam (2m,) the pair forces (normal rows, then tangential); scale: the size of the
    forces of the step (`LinearSolver.solve`'s: a residual below 1e-12 of it is
    round-off), None for the run's largest."""
    b = g.T @ lam
    b[fixed] = 0.0
    r0, r1 = k.getOwnershipRange()
    vec = k.createVecLeft()
    vec.setArray(b[r0:r1])
    x = solver.solve(vec, forces=lam, scale=scale)
    out = to_numpy_all(x)
    x.destroy()
    vec.destroy()
    return out


def mismatch(g: sp.csr_matrix, u: np.ndarray, result) -> np.ndarray:
    """G u minus the LCP's (gap - g0, tau): (2m,), zero when the compliance C used by the
    LCP agrees with the factorization that recovers u. An inexact C (round-off of the
    Schur complement on an ill-conditioned K) shows here; adding it to the free gap and
    tangential displacement and solving again converges to the consistent answer."""
    return g @ u - result.kinematics
