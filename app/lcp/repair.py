"""Basis repair for symmetric LCPs that Lemke's pivoting could not finish.

On an ill-conditioned symmetric positive (semi)definite M (e.g. frictionless contacts of
which some lie 1e-5 apart: near-duplicate columns, condition number 1e10 and more) the
ratio and lexicographic tests can pick bases that are numerically singular, or follow a
path to a false secondary ray, although the LCP has a unique solution. Such an LCP is the
convex problem min 1/2 z'Mz + q'z over z >= 0, i.e. with M = R'R the non-negative least
squares problem min |R z + R^-T q| (Lawson and Hanson's active-set method, which keeps its
own well-conditioned factorization). Its positive set is handed to Lemke as a warm-start
basis: Lemke stays the solver of record, and the answer is checked on the original M.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from scipy.optimize import nnls

SYMMETRY_REL = 1e-12
"""M counts as symmetric when max |M - M'| <= this x max |M|."""


def is_symmetric(M: np.ndarray) -> bool:
    """Whether M is symmetric to SYMMETRY_REL (one pass over M, in column blocks)."""
    n = M.shape[0]
    big = float(np.abs(M).max(initial=0.0))
    for j0 in range(0, n, 256):
        j1 = min(j0 + 256, n)
        if np.abs(M[:, j0:j1] - M[j0:j1].T).max(initial=0.0) > SYMMETRY_REL * big:
            return False
    return True


def qp_basis(M: np.ndarray, q: np.ndarray) -> np.ndarray | None:
    """Positive set (n,) bool of the NNLS form of LCP(M, q) for a symmetric PSD M, or None
    when M is not numerically positive semidefinite (Cholesky fails even with a diagonal
    shift of 1e-8 x max |M_ii|)."""
    n = q.size
    top = float(np.abs(np.diagonal(M)).max(initial=0.0))
    if top == 0.0:
        return None
    shift = 0.0
    while True:
        try:
            R = sla.cholesky(M + shift * np.eye(n), check_finite=False)
            break
        except np.linalg.LinAlgError:
            shift = max(10.0 * shift, 1e-15 * top)
            if shift > 1e-8 * top:
                return None
    b = -sla.solve_triangular(R, q, trans="T", check_finite=False)
    try:
        z, _ = nnls(R, b, maxiter=50 * n + 100)
    except RuntimeError:  # iteration limit
        return None
    return z > 0
