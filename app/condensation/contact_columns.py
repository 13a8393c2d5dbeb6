"""The contact part of a force recovery, u_c = S^-1 G_c^T lambda, from kept columns.

A step's recovery needs S^-1 b_c with b_c = G_c^T lambda, and lambda is non-zero on the
rows of the pairs in contact only (a few hundred of thousands of rows in a many-pair
scene). One solve with the dense Cholesky factor of S reads the whole factor (n_c^2
doubles, hundreds of MB in a 2000-pair scene) for one right-hand side, every step. Here
the columns S^-1 G_c^T e_r are solved once, together, for the rows r that first carry a
force (and the other row of the same pair), and every later step is one product with the
kept columns: u_c = Y lambda_kept. The compliance's own S^-1 G_c^T seeds them with the
pairs of the smallest initial gaps (`prefill`), the first to close. The columns are kept
in a Fortran-order array reserved up to `max_columns` (S's memory at most); when every
row fits, the compliance's own S^-1 G_c^T is kept as it is (no copy). Past `max_columns`,
the step falls back to the one dense solve (None from `apply`). With a quarter of n_c (the
cap before), the rows of the pairs in contact did not fit on cattaneo, multibody and
bonded.toml (up to 110 of 77, 153 of 69, 66 of 64 columns): every step fell back, and the
columns were held for nothing.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

MAX_FRACTION = 1.0
"""Columns kept at most, as a fraction of n_c: their memory stays under S's (the 2m rows of G
are fewer than n_c on a two-sided contact: all of them are kept)."""
MIN_COLUMNS = 64
"""Columns kept at most on a small Schur set (whatever MAX_FRACTION gives)."""


def column_cap(n_c: int, n_rows: int) -> int:
    """Columns kept at most for a Schur set of n_c DOFs and n_rows rows of G."""
    return min(n_rows, max(MIN_COLUMNS, int(MAX_FRACTION * n_c)))


class ContactColumns:
    """S^-1 G_c^T e_r for the rows r of G solved so far (rank 0's).

    gc: G_c, (n_rows, n_c) sparse, rows the pairs' normal rows then their tangential ones
    (n_rows = 2 m) or any other layout (then a row is solved alone); dense_solve: b ->
    S^-1 b for b of shape (n_c, k).
    """

    def __init__(self, gc: sp.spmatrix, dense_solve: Callable[[np.ndarray], np.ndarray],
                 max_columns: int | None = None):
        self.gct = sp.csc_matrix(gc.T)
        n_c, n_rows = self.gct.shape
        self.dense_solve = dense_solve
        self.max_columns = (min(n_rows, max_columns) if max_columns is not None
                            else column_cap(n_c, n_rows))
        self.pos = np.full(n_rows, -1, dtype=np.int64)  # row -> its column in y, or -1
        self.count = 0
        self.y = np.empty((n_c, self.max_columns), order="F")  # pages touched when filled
        self.solves = 0  # dense solves made (fills), for tests and benchmarks

    def prefill(self, y: np.ndarray, pairs_first: np.ndarray) -> None:
        """Keep the columns of the full S^-1 G_c^T `y` (n_c, n_rows) for the pairs in the
        order `pairs_first` (e.g. by initial gap: the first to close), both rows of each,
        as many as `max_columns` holds; when it holds every row, `y` itself (Fortran order)
        in row order."""
        n_rows = self.pos.size
        if self.count:
            return
        if self.max_columns >= n_rows and y.shape == (self.y.shape[0], n_rows) \
                and y.flags.f_contiguous:  # every row: keep y itself
            self.y, self.count = y, n_rows
            self.pos[:] = np.arange(n_rows)
            return
        if n_rows % 2:
            return
        m = n_rows // 2
        rows = np.column_stack([pairs_first, pairs_first + m]).ravel()[: self.max_columns]
        self.y[:, : rows.size] = y[:, rows]
        self.pos[rows] = np.arange(rows.size)
        self.count = rows.size

    def _partners(self, rows: np.ndarray) -> np.ndarray:
        """The rows and, with 2 m rows, the other row of each one's pair; not yet kept."""
        n_rows = self.pos.size
        if n_rows % 2 == 0:
            m = n_rows // 2
            pairs = np.unique(rows % m)
            rows = np.concatenate([pairs, pairs + m])
        rows = np.unique(rows)
        return rows[self.pos[rows] < 0]

    def _fill(self, rows: np.ndarray) -> bool:
        """Solve and keep the columns of `rows` (not yet kept); False when they do not fit."""
        new = self._partners(rows)
        if self.count + new.size > self.max_columns:
            new = rows[self.pos[rows] < 0]  # without the partners
            if self.count + new.size > self.max_columns:
                return False
        cols = slice(self.count, self.count + new.size)
        self.y[:, cols] = self.dense_solve(self.gct[:, new].toarray())
        self.pos[new] = np.arange(cols.start, cols.stop)
        self.count = cols.stop
        self.solves += 1
        return True

    def apply(self, lam: np.ndarray) -> np.ndarray | None:
        """u_c = S^-1 G_c^T lam, (n_c,), for lam (n_rows,); None when the columns it needs
        exceed `max_columns` (then the caller solves with S)."""
        rows = np.flatnonzero(lam)
        if rows.size == 0:
            return np.zeros(self.gct.shape[0])
        missing = rows[self.pos[rows] < 0]
        if missing.size and not self._fill(missing):
            return None
        cols = self.pos[rows]
        end = int(cols.max()) + 1  # the kept columns up to the last one used (a prefix:
        if end > 2 * cols.size:    # the first pairs to close come first), unless sparse
            return self.y[:, cols] @ lam[rows]
        weights = np.zeros(end)
        weights[cols] = lam[rows]
        return self.y[:, :end] @ weights
