"""Scaling of an LCP and the dense helpers shared by the Lemke cores and the crash.

The problem is scaled symmetrically, ``M~ = D M D / mu``, ``q~ = D q / nu`` with D a
positive diagonal of powers of two, so that pivot and tie tolerances are unit free
(contact LCPs mix gap and force units). The LCP is invariant under this:
z = (nu / mu) D z~, w = nu D^-1 w~. M~ is never formed (`ScaledM`).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator

import numpy as np
import scipy.linalg as sla

__all__ = ["ScaledM", "gather", "scaling", "matrix_scaling", "q_scaling", "diagonal_scaling",
           "lu_or_none", "absmax", "row_blocks", "RCOND_MIN"]

BLOCK_ROWS = 256
"""Row-block size for passes over M that need an |M| temporary (no n x n temporaries)."""

RCOND_MIN = 1e-14
"""A basis block whose estimated reciprocal condition number is below this is singular."""


def pow2(x: np.ndarray) -> np.ndarray:
    """Nearest powers of two (so that scaling is exact in floating point)."""
    return np.exp2(np.round(np.log2(x)))


def absmax(a: np.ndarray, axis: int | None = None) -> np.ndarray | np.floating:
    """max |a| (along axis) without an |a| temporary."""
    return np.maximum(a.max(axis=axis), -a.min(axis=axis))


def row_blocks(n: int) -> Iterator[tuple[int, int]]:
    """(start, stop) row ranges of BLOCK_ROWS rows covering 0..n."""
    return ((i, min(i + BLOCK_ROWS, n)) for i in range(0, n, BLOCK_ROWS))


def gather(M: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """M[rows][:, cols] as a new C-order array: one `take` of the flat entries when M is
    C-contiguous (a third faster than np.ix_ indexing for a few hundred rows)."""
    rows, cols = np.asarray(rows, dtype=np.intp), np.asarray(cols, dtype=np.intp)
    if not M.flags.c_contiguous:
        return M[np.ix_(rows, cols)]
    flat = (rows[:, None] * M.shape[1] + cols).reshape(-1)
    return np.take(M.reshape(-1), flat).reshape(rows.size, cols.size)


class ScaledM:
    """The scaled matrix M~ = D M D / mu, never formed: columns and blocks on demand.

    (Forming it would cost an n x n allocation, slow to page in for n in the thousands.)
    """

    def __init__(self, M: np.ndarray, D: np.ndarray, mu: float):
        self.M, self.D, self.mu = M, D, mu
        self.n = D.size
        self.absmax = 1.0  # max |M~| by the choice of mu

    def col(self, j: int) -> np.ndarray:
        """Column j of M~ = D M D / mu, (n,)."""
        return self.M[:, j] * (self.D * (self.D[j] / self.mu))

    def cols(self, idx: np.ndarray) -> np.ndarray:
        """M~[:, idx] as an (n, k) array."""
        return self.M[:, idx] * self.D[:, None] * (self.D[idx] / self.mu)

    def rows(self, idx: np.ndarray) -> np.ndarray:
        """M~[idx, :] as a (k, n) array."""
        return self.M[idx] * (self.D[idx] / self.mu)[:, None] * self.D

    def block(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """M~[rows][:, cols] (a new array, scaled in place)."""
        A = gather(self.M, rows, cols)
        A *= self.D[rows][:, None]
        A *= self.D[cols] / self.mu
        return A

    def sub(self, idx: np.ndarray) -> np.ndarray:
        """M~[idx][:, idx] (a new array, scaled in place)."""
        Di = self.D[idx]
        A = gather(self.M, idx, idx)
        A *= Di[:, None]
        A *= Di / self.mu
        return A

    def matvec(self, v: np.ndarray, part: slice | None = None,
               rows: bool = False) -> np.ndarray:
        """M~ v. part: v is zero outside this index range, so only those columns of M are
        read; with rows=True only the rows of that range are returned (a square block)."""
        if part is None:
            return self.D * (self.M @ (self.D * v)) / self.mu
        blk = self.M[part, part] if rows else self.M[:, part]
        Dr = self.D[part] if rows else self.D
        return Dr * (blk @ (self.D[part] * v[part])) / self.mu

    def rmatvec(self, v: np.ndarray) -> np.ndarray:
        """v^T M~ as an (n,) array."""
        return self.D * ((self.D * v) @ self.M) / self.mu

    def dense(self) -> np.ndarray:
        """M~ = D M D / mu as a dense (n, n) array (a new copy)."""
        return self.D[:, None] * self.M * (self.D / self.mu)


def scaling(M: np.ndarray, q: np.ndarray) -> tuple[ScaledM, np.ndarray, float, float]:
    """Symmetric scaling: (M~, D, mu, nu) with M~ = D M D / mu, q~ = D q / nu.

    D_i = 1 / sqrt(s_i) with s_i = |M_ii| when that is at least 1e-6 times the largest
    entry of row or column i, else that largest entry (1 for an all-zero row and column);
    D, mu and nu are powers of two (exact scaling), mu = max|D M D|, nu = max|D q|.
    One pass over M in row blocks (two when a diagonal entry is too small), in
    `matrix_scaling` (D and mu: M alone).
    """
    D, mu = matrix_scaling(M)
    return ScaledM(M, D, mu), D, mu, q_scaling(D, q)


def q_scaling(D: np.ndarray, q: np.ndarray) -> float:
    """nu of `scaling`: max |D q| as a power of two (1 when q = 0)."""
    nu = float(np.abs(D * q).max(initial=0.0))
    return float(pow2(np.array(nu))) if nu > 0 else 1.0


def matrix_scaling(M: np.ndarray) -> tuple[np.ndarray, float]:
    """(D, mu) of `scaling`: they depend on M alone."""
    n = M.shape[0]
    dg = np.abs(np.diagonal(M))
    # first guess D from the diagonal alone; one pass checks it and gives mu with it
    D = pow2(1.0 / np.sqrt(np.where(dg > 0, dg, 1.0)))
    rmax, cmax, smax = np.zeros(n), np.zeros(n), np.zeros(n)
    for i0, i1 in row_blocks(n):
        a = np.abs(M[i0:i1])
        rmax[i0:i1] = a.max(axis=1)
        np.maximum(cmax, a.max(axis=0), out=cmax)
        a *= D
        smax[i0:i1] = a.max(axis=1) * D[i0:i1]
    rc = np.maximum(rmax, cmax)
    s = np.where(dg >= 1e-6 * rc, dg, rc)
    s[s == 0.0] = 1.0
    D_final = pow2(1.0 / np.sqrt(s))
    if np.array_equal(D_final, D):
        mu = float(smax.max(initial=0.0))
    else:  # some diagonal entries too small: a second pass with the final D
        D = D_final
        mu = 0.0
        for i0, i1 in row_blocks(n):
            mu = max(mu, float(((np.abs(M[i0:i1]) * D).max(axis=1) * D[i0:i1]).max()))
    mu = float(pow2(np.array(mu))) if mu > 0 else 1.0
    return D, mu


def diagonal_scaling(M: np.ndarray, q: np.ndarray) -> tuple[ScaledM, np.ndarray, np.ndarray]:
    """The cheap scaling of a crash (no pass over M): (M~, q~, zfac) with M~ = D M D,
    q~ = D q / nu, z = zfac z~; D_i = 1 / sqrt|M_ii| as a power of two (1 where M_ii = 0),
    nu = max |D q| as a power of two. `scaling` is this where no diagonal entry is tiny
    against its row and column, up to the factor mu."""
    dg = np.abs(np.diagonal(M))
    with np.errstate(divide="ignore", over="ignore"):
        D = pow2(1.0 / np.sqrt(np.where(dg > 0, dg, 1.0)))
    D[~np.isfinite(D) | (D == 0)] = 1.0
    nu = float(np.abs(D * q).max(initial=0.0))
    nu = float(pow2(np.array(nu))) if 0 < nu < np.inf else 1.0
    return ScaledM(M, D, 1.0), D * q / nu, D * nu


def lu_or_none(A: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """LU factors of square A (scipy lu_factor), or None when A is numerically singular."""
    if A.shape[0] == 0:
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        try:
            lu = sla.lu_factor(A, check_finite=False)
        except (ValueError, np.linalg.LinAlgError):
            return None
    if not np.isfinite(lu[0]).all():
        return None
    rcond = sla.lapack.dgecon(lu[0], float(np.abs(A).sum(axis=0).max()))[0]
    return lu if np.isfinite(rcond) and rcond >= RCOND_MIN else None
