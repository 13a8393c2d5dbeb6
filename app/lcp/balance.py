"""Two-sided balancing of an LCP whose rows and columns are in very different units.

LCP(M, q) and LCP(R M C, R q) (R, C positive diagonals) have the same solutions up to
z = C z': w' = R w, and z'_i w'_i = 0 exactly where z_i w_i = 0. Lemke's own scaling is
symmetric (D M D, `app.lcp.scaling`), which cannot balance an M whose rows carry other
factors than its columns: rows scaled by 1e-8..1e8 (R M), or a symmetric scaling D M D
whose off-diagonal entries dwarf the diagonal. There the pivot and tie tolerances, relative
to the largest entry, take real entries for zeros, and Lemke ended on false secondary rays
or "inaccurate" on P-matrices (scripts/check_lcp.py). `balance` finds R, C (powers of
two) by Ruiz's iteration (each row and column divided by the square root of its largest
entry), so that every row and column of R M C has its largest entry in [1/4, 4].
"""

from __future__ import annotations

import numpy as np

from app.lcp.scaling import pow2, row_blocks, scaling

IMBALANCE = 2.0**10
"""An LCP is imbalanced when its largest entry is above this x the smallest row or column
maximum after Lemke's symmetric scaling (`imbalanced`)."""
ITERATIONS = 30
"""Most Ruiz iterations (each one pass over M; the log-imbalance halves per iteration)."""


def _maxima(M: np.ndarray, r: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row and column maxima of |r M c| (one pass, in row blocks)."""
    n = r.size
    rmax, cmax = np.zeros(n), np.zeros(n)
    for i0, i1 in row_blocks(n):
        a = np.abs(M[i0:i1]) * c
        a *= r[i0:i1, None]
        rmax[i0:i1] = a.max(axis=1, initial=0.0)
        np.maximum(cmax, a.max(axis=0, initial=0.0), out=cmax)
    return rmax, cmax


def imbalanced(M: np.ndarray) -> bool:
    """Whether Lemke's symmetric scaling D M D (`app.lcp.scaling.scaling`: Jacobi, or the
    row and column maximum where a diagonal entry is tiny) leaves a row or column whose
    largest entry is below 1 / IMBALANCE of the largest entry (two or three passes)."""
    n = M.shape[0]
    if n == 0:
        return False
    _, D, _, _ = scaling(M, np.zeros(n))
    rmax, cmax = _maxima(M, D, D)
    top = rmax.max()
    if top == 0.0:
        return False
    low = min(rmax[rmax > 0].min(), cmax[cmax > 0].min())
    return bool(top > IMBALANCE * low)


def balance(M: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(R, C) (n,) powers of two with every row and column maximum of |R M C| in [1/4, 4]
    (zero rows and columns keep factor 1), or None when M is not `imbalanced`. For a
    symmetric M, R = C (the iteration treats rows and columns alike), so R M C is
    symmetric."""
    if not imbalanced(M):
        return None
    n = M.shape[0]
    r, c = np.ones(n), np.ones(n)
    for _ in range(ITERATIONS):
        rmax, cmax = _maxima(M, r, c)
        rmax[rmax == 0] = 1.0
        cmax[cmax == 0] = 1.0
        if max(np.abs(np.log2(rmax)).max(), np.abs(np.log2(cmax)).max()) <= 2.0:
            break
        r /= pow2(np.sqrt(rmax))
        c /= pow2(np.sqrt(cmax))
    return r, c
