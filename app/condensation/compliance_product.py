"""C = G_c S^-1 G_c^T with one (n_c, 2m) dense array and C itself alive at the peak.

The plain expression `0.5 * (c + c.T)` of `c = gc @ cho_solve(S, gc.T.toarray())` holds the
right-hand sides, their solution, a C-order copy of it for the sparse product, C, C + C^T
and the result at once. Here the right-hand sides are solved in place (Fortran order, as
LAPACK wants them), C is formed a block of columns at a time from that solution, and
symmetrized in place tile by tile.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

BLOCK = 512
"""Columns of the solution multiplied at a time (its C-order copy: n_c x BLOCK doubles)."""


def symmetrize_in_place(c: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """c <- (c + c^T) / 2 without a second (n, n) array; returns c."""
    n = c.shape[0]
    for i in range(0, n, block):
        ri = slice(i, min(i + block, n))
        d = c[ri, ri]
        d[...] = 0.5 * (d + d.T)
        for j in range(i + block, n, block):
            rj = slice(j, min(j + block, n))
            avg = 0.5 * (c[ri, rj] + c[rj, ri].T)
            c[ri, rj] = avg
            c[rj, ri] = avg.T
    return c


def compliance_product(gc: sp.spmatrix, solve_in_place: Callable[[np.ndarray], np.ndarray],
                       keep: Callable[[np.ndarray], None] | None = None,
                       block: int = BLOCK) -> np.ndarray:
    """(G_c S^-1 G_c^T + its transpose) / 2, (2m, 2m). gc: G_c (2m, n_c) sparse;
    solve_in_place: b (n_c, k) Fortran order -> S^-1 b, allowed to overwrite b; keep:
    called with S^-1 G_c^T (n_c, 2m) before it is freed (to copy columns of it)."""
    gc = sp.csr_matrix(gc)
    n_rows = gc.shape[0]
    y = solve_in_place(np.asfortranarray(gc.T.toarray()))
    c = np.empty((n_rows, n_rows))
    for j in range(0, n_rows, block):
        cols = slice(j, min(j + block, n_rows))
        c[:, cols] = gc @ np.ascontiguousarray(y[:, cols])
    if keep is not None:
        keep(y)
    del y
    return symmetrize_in_place(c, block)
